//! (in progress)
/// An image in linear floating point, RGBA, row 0 at the top.
#[derive(Debug, Clone)]
pub struct Texture {
    pub width: u32,
    pub height: u32,
    pub texels: Vec<[f32; 4]>,
}
