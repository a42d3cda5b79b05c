//! The dual-scattering integrator's settings: the `dual` section of scene files.

use crate::integrators::dual::DualModel;
use crate::integrators::dual::transmittance::LookupSettings;
use crate::lights::Lights;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// The dual-scattering integrator's parameters (Zinke et al. 2008 section 4).
#[derive(Serialize, Deserialize, Debug, Clone)]
#[serde(default, deny_unknown_fields)]
pub struct DualSpec {
    /// Forward scattering density factor d_f in [0, 1].
    pub d_f: f64,
    /// Backscattering density factor d_b in [0, 1].
    pub d_b: f64,
    /// How the light that reaches a fiber through other fibers is modelled.
    pub model: DualModel,
    /// Voxel size of the density grid in scene units (default: chosen from the hair).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub voxel_size: Option<f64>,
    /// A density grid made elsewhere: an OpenVDB file with a float grid `density` of hair length
    /// per unit volume and `fiber_width` metadata, in the hair's final (world) frame. Default:
    /// voxelize the hair.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub density_grid: Option<PathBuf>,
    /// Shadow rays (default) or the precomputed forward-transmittance lookup.
    pub shadows: ShadowMode,
    /// The lookup's resolutions.
    pub lookup: LookupSettings,
    /// Direction samples per camera hit, each a light sample and a sample of F's own sampler,
    /// stratified together: one camera ray and the fiber's per-hit state serve them all
    /// (default: [`DualSpec::light_samples`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub light_samples: Option<u32>,
}

/// The most light samples per camera hit `dual` takes (`dual.light_samples`, converge's
/// `dual-...-K`).
pub const MAX_LIGHT_SAMPLES: u32 = 256;

impl DualSpec {
    /// Light samples per camera hit: the scene's, else 4 under an environment map and 1 under a
    /// sun or a constant sky. Under a map most of a `dual` sample's noise is where its light
    /// direction falls, which more directions per camera ray average away for less than more
    /// camera rays cost; under a sun's small disc the noise is mostly which fibers the camera ray
    /// hits, and more light samples only cost time (docs/dual_scattering.md, "Light samples per camera hit").
    pub fn light_samples(&self, lights: &Lights) -> u32 {
        self.light_samples.unwrap_or(if lights.has_map() { 4 } else { 1 })
    }
}

choices! {
    /// How `dual` finds what lies between a shading point and a light (see [`super::Shadows`]).
    pub enum ShadowMode {
        /// Shadow rays through the real strands and grid marches: crisp hair-on-hair shadows,
        /// and the closest to `path` on the accuracy table (the default).
        Rays = "rays",
        /// The forward-transmittance lookup: deep opacity maps toward the lights, built once per
        /// hair and light (seconds), soft shadows at a few fiber widths.
        Lookup = "lookup",
    }
}

impl Default for DualSpec {
    fn default() -> Self {
        DualSpec {
            d_f: 1.0,
            d_b: 1.0,
            model: DualModel::TwoStream,
            voxel_size: None,
            density_grid: None,
            shadows: ShadowMode::Rays,
            lookup: LookupSettings::default(),
            light_samples: None,
        }
    }
}
