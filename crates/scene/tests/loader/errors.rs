//! Bad input is refused with `file:line: message`, the line being that of the
//! offending key and the message naming it. One rule per test.

use crate::support::{BASE, assert_refused, line_of, parse, with};

const CAM_TAIL: &str = "\n[[material]]\nname = \"m\"\ndiffuse = [0.5, 0.5, 0.5]\nspecular = [0, 0, 0]\nroughness = 0.5\n";

fn camera(body: &str) -> String {
    format!("[camera]\n{body}\n{CAM_TAIL}")
}

fn material(body: &str) -> String {
    with(&format!("\n[[material]]\n{body}\n"))
}

fn object(body: &str) -> String {
    with(&format!("\n[[object]]\nmaterial = \"m\"\n{body}\n"))
}

fn light(body: &str) -> String {
    with(&format!("\n[[light]]\nradiance = [1, 1, 1]\n{body}\n"))
}

const MAT_OK: &str = "diffuse = [0.5, 0.5, 0.5]\nspecular = [0.04, 0.04, 0.04]\nroughness = 0.5";

// ---- TOML itself -------------------------------------------------------

#[test]
fn toml_syntax_error_names_its_line() {
    assert_refused(
        &with("[[object]]\nmaterial = = \"m\"\n"),
        "material = =",
        &["invalid TOML"],
    );
}

#[test]
fn duplicate_key_is_refused() {
    assert_refused(
        &camera("eye = [0,1,-5]\ntarget = [0,0,0]\nfov_y = 40\nfov_y = 50"),
        "fov_y = 50",
        &["invalid TOML"],
    );
}

#[test]
fn empty_file_is_refused_for_missing_camera() {
    let e = parse("").expect_err("refused");
    assert_eq!(e.line, 1);
    assert!(e.message.contains("[camera]"), "{e}");
}

// ---- unknown keys ------------------------------------------------------

#[test]
fn unknown_top_level_table_is_refused() {
    assert_refused(&with("[camra]\neye = [0,0,0]\n"), "[camra]", &["camra"]);
}

#[test]
fn unknown_camera_key_is_refused() {
    assert_refused(
        &camera("eye = [0,1,-5]\ntarget = [0,0,0]\nfov_y = 40\nfov = 40"),
        "fov = 40",
        &["camera", "`fov`"],
    );
}

#[test]
fn unknown_output_key_is_refused() {
    assert_refused(
        &with("[output]\nwidht = 640\n"),
        "widht",
        &["output", "`widht`"],
    );
}

#[test]
fn unknown_material_key_is_refused() {
    assert_refused(
        &material(&format!("name = \"x\"\n{MAT_OK}\nroughnes = 0.5")),
        "roughnes = 0.5",
        &["material", "`roughnes`"],
    );
}

#[test]
fn unknown_object_key_is_refused() {
    assert_refused(
        &object("type = \"sphere\"\ncenter = [0,0,0]\nradius = 1\nradious = 2"),
        "radious",
        &["object 1 (sphere)", "`radious`"],
    );
}

#[test]
fn key_of_another_object_type_is_refused() {
    assert_refused(
        &object("type = \"quad\"\ncenter = [0,0,0]\nu = [1,0,0]\nv = [0,0,1]\nradius = 2"),
        "radius",
        &["`radius`"],
    );
}

#[test]
fn unknown_light_key_is_refused() {
    assert_refused(
        &light("type = \"quad\"\ncenter = [0,3,0]\nu = [1,0,0]\nv = [0,0,1]\ntwosided = true"),
        "twosided",
        &["light 1 (quad)", "`twosided`"],
    );
}

// ---- wrong types and lengths -------------------------------------------

#[test]
fn camera_must_be_a_table() {
    assert_refused(
        &format!("camera = 3\n{CAM_TAIL}"),
        "camera = 3",
        &["camera", "table"],
    );
}

#[test]
fn material_must_be_an_array_of_tables() {
    assert_refused(
        &format!(
            "[camera]\neye = [0,1,-5]\ntarget = [0,0,0]\nfov_y = 40\n[material]\nname = \"m\"\n{MAT_OK}\n"
        ),
        "[material]",
        &["material", "[[material]]"],
    );
}

#[test]
fn vector_of_wrong_length_is_refused() {
    assert_refused(
        &camera("eye = [0, 1]\ntarget = [0,0,0]\nfov_y = 40"),
        "eye = ",
        &["eye", "3 components", "found 2"],
    );
}

#[test]
fn vector_with_a_string_component_is_refused() {
    assert_refused(
        &camera("eye = [0, \"1\", 0]\ntarget = [0,0,0]\nfov_y = 40"),
        "eye = ",
        &["eye[1]", "number", "string"],
    );
}

#[test]
fn number_given_as_string_is_refused() {
    assert_refused(
        &camera("eye = [0,1,-5]\ntarget = [0,0,0]\nfov_y = \"40\""),
        "fov_y",
        &["fov_y", "number", "string"],
    );
}

#[test]
fn vector_given_as_number_is_refused() {
    assert_refused(
        &camera("eye = 5\ntarget = [0,0,0]\nfov_y = 40"),
        "eye = 5",
        &["eye", "array"],
    );
}

#[test]
fn boolean_given_as_string_is_refused() {
    assert_refused(
        &light("type = \"quad\"\ncenter = [0,3,0]\nu = [1,0,0]\nv = [0,0,1]\ntwo_sided = \"yes\""),
        "two_sided",
        &["two_sided", "true or false"],
    );
}

#[test]
fn float_width_is_refused() {
    assert_refused(
        &with("[output]\nwidth = 640.0\n"),
        "width",
        &["width", "integer"],
    );
}

#[test]
fn material_name_must_be_a_string() {
    assert_refused(
        &material(&format!("name = 3\n{MAT_OK}")),
        "name = 3",
        &["name", "string"],
    );
}

// ---- missing keys and sections -----------------------------------------

#[test]
fn missing_camera_is_refused() {
    let text = format!("[output]\nwidth = 10\n{CAM_TAIL}");
    let e = parse(&text).expect_err("refused");
    assert_eq!(e.line, 1);
    assert!(e.message.contains("[camera]"), "{e}");
}

#[test]
fn missing_camera_key_is_refused_at_the_header() {
    assert_refused(
        &camera("eye = [0,1,-5]\nfov_y = 40"),
        "[camera]",
        &["camera", "`target`"],
    );
}

#[test]
fn missing_fov_is_refused() {
    assert_refused(
        &camera("eye = [0,1,-5]\ntarget = [0,0,0]"),
        "[camera]",
        &["`fov_y`"],
    );
}

#[test]
fn missing_material_key_is_refused_at_its_header() {
    let text = with("\n[[material]] # second\nname = \"x\"\ndiffuse = [1,1,1]\nroughness = 0.5\n");
    assert_refused(&text, "# second", &["material \"x\"", "`specular`"]);
}

#[test]
fn missing_object_type_is_refused() {
    assert_refused(
        &with("\n[[object]] # here\nmaterial = \"m\"\ncenter = [0,0,0]\n"),
        "# here",
        &["object 1", "`type`"],
    );
}

#[test]
fn missing_sphere_radius_is_refused() {
    assert_refused(
        &with("\n[[object]] # here\nmaterial = \"m\"\ntype = \"sphere\"\ncenter = [0,0,0]\n"),
        "# here",
        &["`radius`"],
    );
}

#[test]
fn missing_light_radiance_is_refused() {
    assert_refused(
        &with("\n[[light]] # here\ntype = \"quad\"\ncenter = [0,3,0]\nu = [1,0,0]\nv = [0,0,1]\n"),
        "# here",
        &["light 1", "`radiance`"],
    );
}

#[test]
fn missing_object_material_is_refused() {
    assert_refused(
        &with("\n[[object]] # here\ntype = \"sphere\"\ncenter = [0,0,0]\nradius = 1\n"),
        "# here",
        &["`material`"],
    );
}

// ---- non-finite numbers ------------------------------------------------

#[test]
fn nan_in_camera_is_refused() {
    assert_refused(
        &camera("eye = [nan, 1, -5]\ntarget = [0,0,0]\nfov_y = 40"),
        "eye = ",
        &["eye", "NaN", "finite"],
    );
}

#[test]
fn inf_in_object_is_refused() {
    assert_refused(
        &object("type = \"sphere\"\ncenter = [0,0,0]\nradius = inf"),
        "radius",
        &["radius", "inf", "finite"],
    );
}

#[test]
fn negative_inf_in_light_is_refused() {
    assert_refused(
        &light("type = \"quad\"\ncenter = [0,3,0]\nu = [-inf,0,0]\nv = [0,0,1]"),
        "u = [-inf",
        &["u = ", "-inf"],
    );
}

#[test]
fn nan_in_polygon_vertex_is_refused() {
    assert_refused(
        &light("type = \"polygon\"\nvertices = [[0,2,0],[1,2,0],[0,2,nan]]"),
        "vertices",
        &["vertices[2]", "NaN"],
    );
}

#[test]
fn nan_roughness_is_refused() {
    assert_refused(
        &material("name = \"x\"\ndiffuse = [1,1,1]\nspecular = [0,0,0]\nroughness = nan"),
        "roughness = nan",
        &["roughness", "NaN"],
    );
}

#[test]
fn huge_coordinate_is_refused() {
    assert_refused(
        &object("type = \"sphere\"\ncenter = [1e30,0,0]\nradius = 1"),
        "center",
        &["center", "1e8"],
    );
}

// ---- camera rules ------------------------------------------------------

#[test]
fn eye_equal_to_target_is_refused() {
    assert_refused(
        &camera("eye = [1,2,3]\ntarget = [1,2,3]\nfov_y = 40"),
        "target",
        &["target", "equals eye"],
    );
}

#[test]
fn up_parallel_to_view_is_refused() {
    assert_refused(
        &camera("eye = [0,5,0]\ntarget = [0,0,0]\nup = [0,2,0]\nfov_y = 40"),
        "up = ",
        &["up", "parallel"],
    );
}

#[test]
fn default_up_parallel_to_view_is_refused() {
    assert_refused(
        &camera("eye = [0,5,0]\ntarget = [0,0,0]\nfov_y = 40"),
        "target",
        &["up", "default", "parallel"],
    );
}

#[test]
fn zero_up_is_refused() {
    assert_refused(
        &camera("eye = [0,1,-5]\ntarget = [0,0,0]\nup = [0,0,0]\nfov_y = 40"),
        "up = ",
        &["up", "zero"],
    );
}

#[test]
fn fov_180_is_refused() {
    assert_refused(
        &camera("eye = [0,1,-5]\ntarget = [0,0,0]\nfov_y = 180"),
        "fov_y",
        &["fov_y = 180", "(0, 180)"],
    );
}

#[test]
fn fov_zero_is_refused() {
    assert_refused(
        &camera("eye = [0,1,-5]\ntarget = [0,0,0]\nfov_y = 0"),
        "fov_y",
        &["fov_y = 0", "(0, 180)"],
    );
}

#[test]
fn negative_fov_is_refused() {
    assert_refused(
        &camera("eye = [0,1,-5]\ntarget = [0,0,0]\nfov_y = -30"),
        "fov_y",
        &["fov_y = -30"],
    );
}

// ---- output rules ------------------------------------------------------

#[test]
fn zero_width_is_refused() {
    assert_refused(
        &with("[output]\nwidth = 0\nheight = 10\n"),
        "width",
        &["width = 0", "[1, 16384]"],
    );
}

#[test]
fn zero_height_is_refused() {
    assert_refused(&with("[output]\nheight = 0\n"), "height", &["height = 0"]);
}

#[test]
fn too_wide_is_refused() {
    assert_refused(
        &with("[output]\nwidth = 20000\nheight = 10\n"),
        "width",
        &["width = 20000", "16384"],
    );
}

#[test]
fn too_many_pixels_is_refused() {
    assert_refused(
        &with("[output]\nwidth = 16384\nheight = 16384\n"),
        "height",
        &["width x height", "64 Mpixel"],
    );
}

#[test]
fn negative_width_is_refused() {
    assert_refused(&with("[output]\nwidth = -5\n"), "width", &["width = -5"]);
}

// ---- material rules ----------------------------------------------------

#[test]
fn roughness_above_one_is_refused() {
    assert_refused(
        &material("name = \"floor\"\ndiffuse = [1,1,1]\nspecular = [0,0,0]\nroughness = 1.7"),
        "roughness = 1.7",
        &["material \"floor\": roughness = 1.7 is outside [0, 1]"],
    );
}

#[test]
fn negative_roughness_is_refused() {
    assert_refused(
        &material("name = \"floor\"\ndiffuse = [1,1,1]\nspecular = [0,0,0]\nroughness = -0.1"),
        "roughness = -0.1",
        &["roughness = -0.1"],
    );
}

#[test]
fn diffuse_above_one_is_refused() {
    assert_refused(
        &material("name = \"x\"\ndiffuse = [1.2, 0.5, 0.5]\nspecular = [0,0,0]\nroughness = 0.5"),
        "diffuse = ",
        &["material \"x\"", "diffuse = [1.2, 0.5, 0.5]", "[0, 1]"],
    );
}

#[test]
fn negative_specular_is_refused() {
    assert_refused(
        &material(
            "name = \"x\"\ndiffuse = [0.5, 0.5, 0.5]\nspecular = [0, -0.1, 0]\nroughness = 0.5",
        ),
        "specular = ",
        &["specular", "[0, 1]"],
    );
}

#[test]
fn duplicate_material_name_is_refused() {
    assert_refused(
        &material(&format!("name = \"m\" # dup\n{MAT_OK}")),
        "# dup",
        &["name = \"m\"", "already used"],
    );
}

#[test]
fn empty_material_name_is_refused() {
    assert_refused(
        &material(&format!("name = \"\"\n{MAT_OK}")),
        "name = \"\"",
        &["name", "empty"],
    );
}

#[test]
fn unknown_material_reference_is_refused() {
    let text = with(
        "\n[[object]]\nmaterial = \"flor\"\ntype = \"sphere\"\ncenter = [0,0,0]\nradius = 1\n",
    );
    assert_refused(&text, "\"flor\"", &["material = \"flor\"", "not defined"]);
}

// ---- object rules ------------------------------------------------------

#[test]
fn unknown_object_type_is_refused() {
    assert_refused(
        &object("type = \"cone\"\ncenter = [0,0,0]"),
        "cone",
        &["type = \"cone\"", "quad, box, sphere, mesh"],
    );
}

#[test]
fn zero_area_quad_is_refused() {
    assert_refused(
        &object("type = \"quad\"\ncenter = [0,0,0]\nu = [1,0,0]\nv = [2,0,0]"),
        "v = ",
        &["u = [1, 0, 0]", "v = [2, 0, 0]", "zero area"],
    );
}

#[test]
fn zero_length_quad_edge_is_refused() {
    assert_refused(
        &object("type = \"quad\"\ncenter = [0,0,0]\nu = [0,0,0]\nv = [2,0,0]"),
        "v = ",
        &["zero area"],
    );
}

#[test]
fn zero_size_box_is_refused() {
    assert_refused(
        &object("type = \"box\"\ncenter = [0,0,0]\nsize = [1, 0, 1]"),
        "size",
        &["size = [1, 0, 1]", "> 0"],
    );
}

#[test]
fn negative_size_box_is_refused() {
    assert_refused(
        &object("type = \"box\"\ncenter = [0,0,0]\nsize = [1, 1, -1]"),
        "size",
        &["size"],
    );
}

#[test]
fn zero_radius_sphere_is_refused() {
    assert_refused(
        &object("type = \"sphere\"\ncenter = [0,0,0]\nradius = 0"),
        "radius",
        &["radius = 0", "> 0"],
    );
}

#[test]
fn negative_radius_sphere_is_refused() {
    assert_refused(
        &object("type = \"sphere\"\ncenter = [0,0,0]\nradius = -2"),
        "radius",
        &["radius = -2"],
    );
}

#[test]
fn too_many_subdivisions_are_refused() {
    assert_refused(
        &object("type = \"sphere\"\ncenter = [0,0,0]\nradius = 1\nsubdivisions = 12"),
        "subdivisions",
        &["subdivisions = 12", "[0, 9]"],
    );
}

#[test]
fn negative_subdivisions_are_refused() {
    assert_refused(
        &object("type = \"sphere\"\ncenter = [0,0,0]\nradius = 1\nsubdivisions = -1"),
        "subdivisions",
        &["subdivisions = -1"],
    );
}

#[test]
fn mesh_without_path_is_refused() {
    assert_refused(
        &with("\n[[object]] # here\nmaterial = \"m\"\ntype = \"mesh\"\n"),
        "# here",
        &["`path`"],
    );
}

#[test]
fn mesh_scale_of_wrong_length_is_refused() {
    assert_refused(
        &object("type = \"mesh\"\npath = \"x.obj\"\nscale = [1, 2]"),
        "scale",
        &["scale", "3 components"],
    );
}

#[test]
fn mesh_nan_rotation_is_refused() {
    assert_refused(
        &object("type = \"mesh\"\npath = \"x.obj\"\nrotate_y = nan"),
        "rotate_y",
        &["rotate_y", "NaN"],
    );
}

// ---- light rules -------------------------------------------------------

#[test]
fn unknown_light_type_is_refused() {
    assert_refused(
        &light("type = \"sphere\""),
        "type = ",
        &["type = \"sphere\"", "quad, polygon"],
    );
}

#[test]
fn negative_radiance_is_refused() {
    let text = with(
        "\n[[light]]\ntype = \"quad\"\ncenter = [0,3,0]\nu = [1,0,0]\nv = [0,0,1]\nradiance = [1, -1, 1]\n",
    );
    assert_refused(&text, "radiance", &["radiance = [1, -1, 1]", "negative"]);
}

#[test]
fn zero_area_quad_light_is_refused() {
    assert_refused(
        &light("type = \"quad\"\ncenter = [0,3,0]\nu = [1,0,0]\nv = [-3,0,0]"),
        "v = ",
        &["light 1 (quad)", "zero area"],
    );
}

#[test]
fn polygon_with_two_vertices_is_refused() {
    assert_refused(
        &light("type = \"polygon\"\nvertices = [[0,0,0],[1,0,0]]"),
        "vertices",
        &["vertices", "3 to 8", "found 2"],
    );
}

#[test]
fn polygon_with_nine_vertices_is_refused() {
    let verts: Vec<String> = (0..9)
        .map(|k| {
            let t = (k as f32 * 40.0).to_radians();
            format!("[{}, 2, {}]", t.cos(), t.sin())
        })
        .collect();
    assert_refused(
        &light(&format!(
            "type = \"polygon\"\nvertices = [{}]",
            verts.join(", ")
        )),
        "vertices",
        &["3 to 8", "found 9"],
    );
}

#[test]
fn collinear_polygon_is_refused() {
    assert_refused(
        &light("type = \"polygon\"\nvertices = [[0,2,0],[1,2,0],[2,2,0]]"),
        "vertices",
        &["vertices", "collinear"],
    );
}

#[test]
fn polygon_with_repeated_vertex_is_refused() {
    assert_refused(
        &light("type = \"polygon\"\nvertices = [[0,2,0],[1,2,0],[1,2,0],[0,2,1]]"),
        "vertices",
        &["vertices", "coincide"],
    );
}

#[test]
fn non_planar_polygon_is_refused() {
    assert_refused(
        &light("type = \"polygon\"\nvertices = [[0,2,0],[1,2,0],[1,2.3,1],[0,2,1]]"),
        "vertices",
        &["vertices", "not planar", "vertex"],
    );
}

#[test]
fn planarity_tolerance_is_relative_to_size() {
    // The same 0.3% bend is fine on a 1000-unit light and on a 1-unit one
    // scaled down; only the relative deviation matters.
    let big =
        light("type = \"polygon\"\nvertices = [[0,2,0],[1000,2,0],[1000,2.0005,1000],[0,2,1000]]");
    assert!(parse(&big).is_ok(), "{:?}", parse(&big).err());
    let bad =
        light("type = \"polygon\"\nvertices = [[0,2,0],[1000,2,0],[1000,12,1000],[0,2,1000]]");
    assert!(parse(&bad).is_err());
}

#[test]
fn non_convex_polygon_is_refused() {
    // An arrowhead: vertex 3 points inwards.
    assert_refused(
        &light("type = \"polygon\"\nvertices = [[0,2,0],[0,2,2],[2,2,1],[0.5,2,1]]"),
        "vertices",
        &["vertices", "not convex", "vertex"],
    );
}

#[test]
fn bow_tie_polygon_is_refused() {
    // Inconsistent winding: the edges cross.
    assert!(
        parse(&light(
            "type = \"polygon\"\nvertices = [[0,2,0],[1,2,1],[1,2,0],[0,2,1]]"
        ))
        .is_err()
    );
    assert_refused(
        &light("type = \"polygon\"\nvertices = [[0,2,0],[1,2,1],[1,2,0],[0,2,1]]"),
        "vertices",
        &["vertices"],
    );
}

#[test]
fn self_overlapping_star_polygon_is_refused() {
    // A pentagram: every turn goes the same way but the edges wind twice.
    let verts: Vec<String> = (0..5)
        .map(|k| {
            let t = (k as f32 * 144.0).to_radians();
            format!("[{}, 2, {}]", t.cos(), t.sin())
        })
        .collect();
    assert_refused(
        &light(&format!(
            "type = \"polygon\"\nvertices = [{}]",
            verts.join(", ")
        )),
        "vertices",
        &["self-overlapping"],
    );
}

#[test]
fn polygon_vertices_must_be_an_array() {
    assert_refused(
        &light("type = \"polygon\"\nvertices = \"square\""),
        "vertices",
        &["vertices", "array"],
    );
}

#[test]
fn polygon_vertex_of_wrong_length_is_refused() {
    assert_refused(
        &light("type = \"polygon\"\nvertices = [[0,2,0],[1,2],[0,2,1]]"),
        "vertices",
        &["vertices[1]", "3 components"],
    );
}

#[test]
fn error_on_multiline_vertices_points_at_the_key() {
    let text = light("type = \"polygon\"\nvertices = [\n  [0,2,0],\n  [1,2,0],\n  [2,2,0],\n]");
    assert_refused(&text, "vertices = [", &["collinear"]);
}

#[test]
fn second_light_is_named_by_index() {
    let text = format!(
        "{BASE}\n[[light]]\ntype = \"quad\"\ncenter = [0,3,0]\nu = [1,0,0]\nv = [0,0,1]\nradiance = [1,1,1]\n\n[[light]]\ntype = \"quad\"\ncenter = [0,3,0]\nu = [1,0,0]\nv = [0,0,1]\nradiance = [1,1,-1] # bad\n"
    );
    assert_refused(&text, "# bad", &["light 2 (quad)", "radiance"]);
    assert!(line_of(&text, "# bad") > 20);
}

#[test]
fn quad_too_small_for_f32_is_refused() {
    assert_refused(
        &light("type = \"quad\"\ncenter = [0,3,0]\nu = [1e-30,0,0]\nv = [0,0,1e-30]"),
        "v = ",
        &["zero area"],
    );
}

#[test]
fn denormal_up_is_refused() {
    assert_refused(
        &camera("eye = [0,1,-5]\ntarget = [0,0,0]\nup = [0,1e-40,0]\nfov_y = 40"),
        "up = ",
        &["up"],
    );
}
