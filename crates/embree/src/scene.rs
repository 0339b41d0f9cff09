//! Building a scene from triangle meshes, and single-ray queries on it.

use std::mem::ManuallyDrop;

use glam::Vec3;

use super::context::{self, INVALID_GEOMETRY_ID};
use super::device::Device;
use super::error::EmbreeError;
use super::sys;

/// What a mesh is for, which decides which rays can hit it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GeometryRole {
    /// Hit by camera rays and blocks shadow rays.
    Occluder,
    /// Hit by camera rays only (area-light emitters): a shadow ray toward a
    /// point on a light must not be blocked by the light itself.
    CameraOnly,
}

/// How occluded* queries skip `CameraOnly` geometry.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShadowStrategy {
    /// Geometry masks: one BVH, shadow rays carry a mask that excludes
    /// `CameraOnly`. Needs an Embree built with ray masks.
    RayMask,
    /// A second scene holding only occluders, used by occluded* queries.
    /// Costs a second BVH; works on any Embree build.
    SeparateScene,
}

/// Geometry mask bit of `Occluder` meshes.
const MASK_OCCLUDER: u32 = 0b01;
/// Geometry mask bit of `CameraOnly` meshes.
const MASK_CAMERA_ONLY: u32 = 0b10;
/// Camera rays see every role.
pub(crate) const RAY_MASK_ALL: u32 = u32::MAX;

/// Collects meshes; [`SceneBuilder::commit`] turns it into a queryable [`Scene`].
pub struct SceneBuilder<'d> {
    device: &'d Device,
    strategy: ShadowStrategy,
    /// Every mesh; camera rays go here.
    all: sys::RTCScene,
    /// Occluders only; `Some` with `ShadowStrategy::SeparateScene`.
    occluders: Option<sys::RTCScene>,
    next_id: u32,
    camera_only_count: u32,
}

impl<'d> SceneBuilder<'d> {
    /// A robust, high-quality scene, with the shadow strategy the device supports.
    pub fn new(device: &'d Device) -> Result<Self, EmbreeError> {
        let strategy = if device.ray_mask_supported() {
            ShadowStrategy::RayMask
        } else {
            ShadowStrategy::SeparateScene
        };
        Self::with_strategy(device, strategy)
    }

    /// Like [`SceneBuilder::new`] with an explicit strategy (tests use it to
    /// exercise the fallback on an Embree that has ray masks).
    /// `RayMask` on a device without mask support is refused.
    pub fn with_strategy(
        device: &'d Device,
        strategy: ShadowStrategy,
    ) -> Result<Self, EmbreeError> {
        if strategy == ShadowStrategy::RayMask && !device.ray_mask_supported() {
            return Err(EmbreeError::Unsupported(
                "ray masks (this Embree was built without EMBREE_RAY_MASK)",
            ));
        }
        let all = new_scene(device)?;
        let mut builder = SceneBuilder {
            device,
            strategy,
            all,
            occluders: None,
            next_id: 0,
            camera_only_count: 0,
        };
        if strategy == ShadowStrategy::SeparateScene {
            builder.occluders = Some(new_scene(device)?);
        }
        Ok(builder)
    }

    /// Adds a triangle mesh; returns its geometry id (0, 1, 2, ... in call
    /// order). The data is copied into Embree-owned buffers.
    pub fn add_triangles(
        &mut self,
        positions: &[Vec3],
        indices: &[[u32; 3]],
        role: GeometryRole,
    ) -> Result<u32, EmbreeError> {
        validate(positions, indices)?;
        let device = self.device;
        device.check("before add_triangles")?;
        // SAFETY: the device is live (borrowed for 'd).
        let geom = unsafe { sys::rtcNewGeometry(device.raw(), sys::RTC_GEOMETRY_TYPE_TRIANGLE) };
        if geom.is_null() {
            device.check("rtcNewGeometry")?;
            return Err(EmbreeError::NullHandle {
                call: "rtcNewGeometry",
                code_name: "no error reported",
            });
        }
        // Releasing our reference on every path: attached scenes hold their own.
        let result = self.fill_and_attach(geom, positions, indices, role);
        // SAFETY: `geom` is live and this drops only the reference we own.
        unsafe { sys::rtcReleaseGeometry(geom) };
        result
    }

    fn fill_and_attach(
        &mut self,
        geom: sys::RTCGeometry,
        positions: &[Vec3],
        indices: &[[u32; 3]],
        role: GeometryRole,
    ) -> Result<u32, EmbreeError> {
        let device = self.device;
        // rtcSetNewGeometryBuffer over-allocates vertex buffers itself so the
        // last vertex can be read with a 16-byte load (Embree API docs), so
        // exactly `positions.len()` items are requested.
        // SAFETY: `geom` is a live geometry; format, stride and count describe
        // a tightly packed float3 array, which Embree allocates and owns.
        let vptr = unsafe {
            sys::rtcSetNewGeometryBuffer(
                geom,
                sys::RTC_BUFFER_TYPE_VERTEX,
                0,
                sys::RTC_FORMAT_FLOAT3,
                12,
                positions.len(),
            )
        };
        device.check("rtcSetNewGeometryBuffer(vertex)")?;
        // SAFETY: as above, for a packed uint3 index array.
        let iptr = unsafe {
            sys::rtcSetNewGeometryBuffer(
                geom,
                sys::RTC_BUFFER_TYPE_INDEX,
                0,
                sys::RTC_FORMAT_UINT3,
                12,
                indices.len(),
            )
        };
        device.check("rtcSetNewGeometryBuffer(index)")?;
        if (vptr.is_null() && !positions.is_empty()) || (iptr.is_null() && !indices.is_empty()) {
            return Err(EmbreeError::NullHandle {
                call: "rtcSetNewGeometryBuffer",
                code_name: "no error reported",
            });
        }
        let flat_positions: Vec<f32> = positions.iter().flat_map(|p| p.to_array()).collect();
        let flat_indices: Vec<u32> = indices.iter().flatten().copied().collect();
        if !flat_positions.is_empty() {
            // SAFETY: Embree allocated `positions.len()` items of 12 bytes at
            // `vptr` (16-byte aligned, at least 4-byte), i.e. exactly
            // `flat_positions.len()` f32s; the regions cannot overlap.
            unsafe {
                std::ptr::copy_nonoverlapping(
                    flat_positions.as_ptr(),
                    vptr as *mut f32,
                    flat_positions.len(),
                )
            };
        }
        if !flat_indices.is_empty() {
            // SAFETY: as above: `indices.len()` items of 3 u32s at `iptr`.
            unsafe {
                std::ptr::copy_nonoverlapping(
                    flat_indices.as_ptr(),
                    iptr as *mut u32,
                    flat_indices.len(),
                )
            };
        }
        let mask = match role {
            GeometryRole::Occluder => MASK_OCCLUDER,
            GeometryRole::CameraOnly => MASK_CAMERA_ONLY,
        };
        // SAFETY: `geom` is live; masks, build quality and commit are plain
        // setters on a geometry no other thread can see yet.
        unsafe {
            sys::rtcSetGeometryMask(geom, mask);
            sys::rtcCommitGeometry(geom);
        }
        device.check("rtcCommitGeometry")?;
        let id = self.next_id;
        // SAFETY: `self.all` is a live, uncommitted scene and `geom` a
        // committed geometry of the same device; attaching by id keeps geometry
        // ids equal to call order.
        unsafe { sys::rtcAttachGeometryByID(self.all, geom, id) };
        device.check("rtcAttachGeometryByID")?;
        if let (Some(occluders), GeometryRole::Occluder) = (self.occluders, role) {
            // SAFETY: as above; Embree allows one geometry in several scenes,
            // and ids in the occluder scene are never shown to callers.
            unsafe { sys::rtcAttachGeometry(occluders, geom) };
            device.check("rtcAttachGeometry(occluders)")?;
        }
        self.next_id += 1;
        if role == GeometryRole::CameraOnly {
            self.camera_only_count += 1;
        }
        Ok(id)
    }

    /// Builds the BVH(s). The result can only be queried, never modified.
    pub fn commit(self) -> Result<Scene<'d>, EmbreeError> {
        // The handles move into `Scene` (whose Drop releases them), so the
        // builder's Drop must not run.
        let this = ManuallyDrop::new(self);
        let device = this.device;
        let mut scene = Scene {
            device,
            all: this.all,
            occluders: this.occluders,
            shadow_mask: match this.strategy {
                ShadowStrategy::RayMask => MASK_OCCLUDER,
                ShadowStrategy::SeparateScene => RAY_MASK_ALL,
            },
        };
        if this.camera_only_count == 0 {
            // Nothing to hide from shadow rays: a second BVH would be pure cost.
            if let Some(occluders) = scene.occluders.take() {
                // SAFETY: `occluders` is live and owned by us; nothing else uses it.
                unsafe { sys::rtcReleaseScene(occluders) };
            }
        }
        device.check("before rtcCommitScene")?;
        // SAFETY: `scene.all` is live and not yet shared with other threads.
        unsafe { sys::rtcCommitScene(scene.all) };
        device.check("rtcCommitScene")?;
        if let Some(occluders) = scene.occluders {
            // SAFETY: as above.
            unsafe { sys::rtcCommitScene(occluders) };
            device.check("rtcCommitScene(occluders)")?;
        }
        Ok(scene)
    }
}

impl Drop for SceneBuilder<'_> {
    fn drop(&mut self) {
        // SAFETY: both handles are live and owned by this builder alone.
        unsafe {
            sys::rtcReleaseScene(self.all);
            if let Some(occluders) = self.occluders {
                sys::rtcReleaseScene(occluders);
            }
        }
    }
}

fn new_scene(device: &Device) -> Result<sys::RTCScene, EmbreeError> {
    // SAFETY: the device is live.
    let scene = unsafe { sys::rtcNewScene(device.raw()) };
    device.check("rtcNewScene")?;
    if scene.is_null() {
        return Err(EmbreeError::NullHandle {
            call: "rtcNewScene",
            code_name: "no error reported",
        });
    }
    // SAFETY: `scene` is live and private to us. ROBUST stops rays leaking
    // through shared edges; HIGH quality pays off because scenes are static.
    unsafe {
        sys::rtcSetSceneFlags(scene, sys::RTC_SCENE_FLAG_ROBUST);
        sys::rtcSetSceneBuildQuality(scene, sys::RTC_BUILD_QUALITY_HIGH);
    }
    if let Err(e) = device.check("rtcSetSceneFlags") {
        // SAFETY: `scene` is live and owned only by us.
        unsafe { sys::rtcReleaseScene(scene) };
        return Err(e);
    }
    Ok(scene)
}

/// Checks what Embree would not: it trusts indices and positions blindly.
fn validate(positions: &[Vec3], indices: &[[u32; 3]]) -> Result<(), EmbreeError> {
    if u32::try_from(positions.len()).is_err() {
        return Err(EmbreeError::TooLarge {
            what: "vertices",
            count: positions.len(),
        });
    }
    if u32::try_from(indices.len()).is_err() {
        return Err(EmbreeError::TooLarge {
            what: "triangles",
            count: indices.len(),
        });
    }
    if let Some((vertex, p)) = positions.iter().enumerate().find(|(_, p)| !p.is_finite()) {
        return Err(EmbreeError::NonFinitePosition {
            vertex,
            position: p.to_array(),
        });
    }
    for (triangle, tri) in indices.iter().enumerate() {
        if let Some(&index) = tri.iter().find(|&&i| i as usize >= positions.len()) {
            return Err(EmbreeError::IndexOutOfRange {
                triangle,
                index,
                vertex_count: positions.len(),
            });
        }
    }
    Ok(())
}

/// A committed, immutable scene. Queries are thread-safe.
pub struct Scene<'d> {
    device: &'d Device,
    all: sys::RTCScene,
    occluders: Option<sys::RTCScene>,
    shadow_mask: u32,
}

// SAFETY: a committed Embree scene is never modified again (no method takes
// `&mut self` or calls an Embree setter), and Embree documents rtcIntersect* /
// rtcOccluded* on a committed scene as thread-safe. Release happens in Drop,
// which needs exclusive ownership.
unsafe impl Send for Scene<'_> {}
// SAFETY: as above: `&Scene` only offers concurrent-safe queries.
unsafe impl Sync for Scene<'_> {}

impl Drop for Scene<'_> {
    fn drop(&mut self) {
        // SAFETY: both handles are live and owned by this scene alone; no
        // query can be running, since those borrow `self`.
        unsafe {
            sys::rtcReleaseScene(self.all);
            if let Some(occluders) = self.occluders {
                sys::rtcReleaseScene(occluders);
            }
        }
    }
}

/// The closest hit of a single ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Ray parameter of the hit (distance if `dir` is unit length).
    pub t: f32,
    /// Geometry id returned by [`SceneBuilder::add_triangles`].
    pub geom_id: u32,
    /// Triangle index within the mesh.
    pub prim_id: u32,
    /// Barycentric weight of vertex 1.
    pub u: f32,
    /// Barycentric weight of vertex 2.
    pub v: f32,
    /// Embree's unnormalised geometric normal, `(v1 - v0) x (v2 - v0)`: it
    /// faces the side from which the winding looks counter-clockwise.
    pub ng: Vec3,
}

impl Scene<'_> {
    /// The device this scene was built on.
    pub fn device(&self) -> &Device {
        self.device
    }

    /// Camera-ray handle: every mesh.
    pub(crate) fn raw_all(&self) -> sys::RTCScene {
        self.all
    }

    /// Shadow-ray handle and mask: occluders only.
    pub(crate) fn raw_shadow(&self) -> (sys::RTCScene, u32) {
        (self.occluders.unwrap_or(self.all), self.shadow_mask)
    }

    /// Closest hit along `org + t * dir`, `t` in `[tnear, tfar]`, any role.
    pub fn intersect1(&self, org: Vec3, dir: Vec3, tnear: f32, tfar: f32) -> Option<Hit> {
        let mut rh = sys::RTCRayHit {
            ray: ray1(org, dir, tnear, tfar, RAY_MASK_ALL),
            hit: sys::RTCHit::default(),
        };
        rh.hit.geomID = INVALID_GEOMETRY_ID;
        rh.hit.instID.fill(INVALID_GEOMETRY_ID);
        // SAFETY: `self.all` is committed and lives as long as `self`.
        unsafe { context::intersect1(self.all, &mut rh) };
        (rh.hit.geomID != INVALID_GEOMETRY_ID).then(|| Hit {
            t: rh.ray.tfar,
            geom_id: rh.hit.geomID,
            prim_id: rh.hit.primID,
            u: rh.hit.u,
            v: rh.hit.v,
            ng: Vec3::new(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z),
        })
    }

    /// Whether any occluder lies along `org + t * dir`, `t` in `[tnear, tfar]`.
    /// `CameraOnly` meshes never occlude.
    pub fn occluded1(&self, org: Vec3, dir: Vec3, tnear: f32, tfar: f32) -> bool {
        let (scene, mask) = self.raw_shadow();
        let mut ray = ray1(org, dir, tnear, tfar, mask);
        // SAFETY: `scene` is committed and lives as long as `self`.
        unsafe { context::occluded1(scene, &mut ray) };
        // Embree marks an occluded ray by setting tfar to -inf; a ray that came
        // in with tfar = -inf is empty and cannot be occluded.
        ray.tfar == f32::NEG_INFINITY && tfar != f32::NEG_INFINITY
    }
}

fn ray1(org: Vec3, dir: Vec3, tnear: f32, tfar: f32, mask: u32) -> sys::RTCRay {
    sys::RTCRay {
        org_x: org.x,
        org_y: org.y,
        org_z: org.z,
        tnear,
        dir_x: dir.x,
        dir_y: dir.y,
        dir_z: dir.z,
        time: 0.0,
        tfar,
        mask,
        id: 0,
        flags: 0,
    }
}
