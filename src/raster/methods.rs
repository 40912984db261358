//! What a render does, decided once from the scene and its options: the
//! multiple scattering the model takes, which fiber counts are built,
//! whether an environment is shaded as lights, whether shadows are traced,
//! whether coverage samples shade the near field. The set-up, the shader
//! and the memory estimate read these instead of re-deriving them, and the
//! model × option combinations that have no meaning are refused here.

use super::env_light;
use super::scene::{HairShading, MultipleScattering, RenderOptions, Scene, Transparency};
use super::shadow::ShadowModel;

/// A combination of model and options that has no meaning: the option's
/// name and why.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MethodError {
    pub option: &'static str,
    pub message: &'static str,
}

impl std::fmt::Display for MethodError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}: {}", self.option, self.message)
    }
}

/// The methods of one render (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Methods {
    /// The option, or the model's default (KarisHair: its own term;
    /// ChiangHair and DEonHair: none).
    pub multiple_scattering: MultipleScattering,
    /// Dual scattering ([`crate::fiber::dual`]).
    pub dual: bool,
    /// Multiple scattering through the volume ([`super::volume`]).
    pub volume: bool,
    /// Per shadowed light, the fiber count towards it (the `density`
    /// shadow model, and dual scattering).
    pub fiber_counts: bool,
    /// Hair's own shadow from the fiber count (shadow model `density`).
    pub count_shadows: bool,
    /// The counts hold the fibers away from each light too (two-stream
    /// back scattering; nothing else reads them).
    pub counts_behind: bool,
    /// The environment is shaded as directional lights with fiber counts
    /// (every model but KarisHair, and KarisHair under dual scattering);
    /// false when the scene has no environment.
    pub environment_as_lights: bool,
    /// Shadow rays through the strands (shadow model `traced`).
    pub traced: bool,
    /// Coverage samples shade ChiangHair's single scattering by the near
    /// field at each sample's offset (per-pixel shading only).
    pub near_field: bool,
}

impl Methods {
    /// The multiple scattering `opts` ask of `scene`'s model: the option,
    /// or the model's default.
    fn multiple_scattering(scene: &Scene, opts: &RenderOptions) -> MultipleScattering {
        opts.multiple_scattering.unwrap_or(match scene.hair {
            HairShading::Karis(_) => MultipleScattering::Karis,
            HairShading::ChiangFar(_) | HairShading::DEon(_) => MultipleScattering::None,
        })
    }

    /// Refuses the combinations of the scene's model and the options that
    /// have no meaning (the bindings call this before rendering).
    pub fn check(scene: &Scene, opts: &RenderOptions) -> Result<(), MethodError> {
        match (&scene.hair, Self::multiple_scattering(scene, opts)) {
            (HairShading::ChiangFar(_) | HairShading::DEon(_), MultipleScattering::Karis) => {
                Err(MethodError {
                    option: "multiple_scattering",
                    message: "'karis' is KarisHair's own term; ChiangHair takes 'dual' or 'none', DEonHair 'none'",
                })
            }
            (HairShading::DEon(_), MultipleScattering::Dual) => {
                Err(MethodError {
                    option: "multiple_scattering",
                    message: "'dual' is not available for DEonHair (use 'none')",
                })
            }
            (HairShading::DEon(_), MultipleScattering::Volume) => {
                Err(MethodError {
                    option: "multiple_scattering",
                    message: "'volume' is not available for DEonHair (use 'none')",
                })
            }
            _ => Ok(()),
        }
    }

    /// The methods of a render of `scene` with `opts` (a combination
    /// [`Self::check`] refuses renders without the meaningless part).
    pub fn new(scene: &Scene, opts: &RenderOptions) -> Self {
        let ms = Self::multiple_scattering(scene, opts);
        let dual = ms == MultipleScattering::Dual && !matches!(scene.hair, HairShading::DEon(_));
        let count_shadows = opts.shadow_model == ShadowModel::Density;
        Self {
            multiple_scattering: ms,
            dual,
            volume: ms == MultipleScattering::Volume && !matches!(scene.hair, HairShading::DEon(_)),
            fiber_counts: count_shadows || dual,
            count_shadows,
            counts_behind: dual && opts.dual_backscatter == super::scene::Backscatter::TwoStream,
            environment_as_lights: scene.environment.is_some()
                && env_light::as_lights(&scene.hair, ms),
            traced: opts.shadow_model == ShadowModel::Traced,
            near_field: opts.near_field
                && matches!(opts.transparency, Transparency::Coverage(_))
                && !opts.vertex_shading
                && matches!(scene.hair, HairShading::ChiangFar(_)),
        }
    }
}
