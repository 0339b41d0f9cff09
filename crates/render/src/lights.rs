//! The scene's lights in every form the renderer reads them in, prepared
//! together once per world: the forms depend only on the declared lights,
//! so preparing them per frame or per band would repeat the same work, and
//! keeping them side by side keeps light `i` the same light in every form.

use penumbra_kernels::sampling::light::PreparedLight;
use penumbra_kernels::shading::ShadingLight;
use penumbra_kernels::shading::light_bound::LightExtent;
use penumbra_kernels::shading::u_batch::BatchLight;
use penumbra_scene::Light;

/// One entry per declared light, in the scene's order, in each form.
#[derive(Debug, Clone)]
pub struct Lights {
    declared: Vec<Light>,
    sampling: Vec<PreparedLight>,
    shading: Vec<ShadingLight>,
    batch: Vec<BatchLight>,
    extents: Vec<LightExtent>,
}

impl Lights {
    pub fn new(declared: &[Light]) -> Lights {
        Lights {
            declared: declared.to_vec(),
            sampling: declared.iter().map(PreparedLight::new).collect(),
            shading: declared.iter().map(ShadingLight::new).collect(),
            batch: declared.iter().map(BatchLight::new).collect(),
            extents: declared.iter().map(LightExtent::new).collect(),
        }
    }

    /// The lights as the scene declares them (geometry and radiance).
    #[inline]
    pub fn declared(&self) -> &[Light] {
        &self.declared
    }

    /// Per-light sampling data that does not depend on the shading point.
    #[inline]
    pub fn sampling(&self) -> &[PreparedLight] {
        &self.sampling
    }

    /// Per-light data of the scalar analytic `U`.
    #[inline]
    pub fn shading(&self) -> &[ShadingLight] {
        &self.shading
    }

    /// Per-light data of the batched analytic `U`.
    #[inline]
    pub fn batch(&self) -> &[BatchLight] {
        &self.batch
    }

    /// Per-light extents for the bounds of the `U` stage's light culling.
    #[inline]
    pub fn extents(&self) -> &[LightExtent] {
        &self.extents
    }

    #[inline]
    pub fn len(&self) -> usize {
        self.declared.len()
    }

    #[inline]
    pub fn is_empty(&self) -> bool {
        self.declared.is_empty()
    }
}
