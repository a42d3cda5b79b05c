//! What the dual integrator precomputes for a hair and its lights: the fiber's tables, the
//! hair's density grid and, for `dual.shadows` "lookup", the forward-transmittance lookup.

use crate::error::Result;
use crate::integrators::dual::cache::Cache;
use crate::integrators::dual::options::{DualSpec, ShadowMode};
use crate::integrators::dual::transmittance::ForwardLookup;
use crate::lights::Lights;
use crate::progress::Progress;
use precompute::density::{DensityGrid, read_vdb};
use precompute::fiber::FiberParams;
use precompute::strands::Strands;
use precompute::tables::Tables;

/// What the dual integrator precomputes for a scene.
pub struct DualInputs {
    pub tables: Tables,
    pub grid: DensityGrid,
    pub lookup: Option<ForwardLookup>,
}

impl DualInputs {
    /// The inputs from `cache` (computed there when missing), or the settings' own density grid
    /// file.
    pub fn load(
        fiber: &FiberParams,
        d: &DualSpec,
        strands: &Strands,
        lights: &Lights,
        cache: &Cache,
        progress: &dyn Progress,
    ) -> Result<DualInputs> {
        let tables = cache.tables(fiber, d.d_b, progress)?;
        let grid = match &d.density_grid {
            Some(path) => read_vdb(path, "density")?.with_orientation(strands),
            None => cache.density(strands, d.voxel_size, progress)?,
        };
        let lookup = match d.shadows {
            ShadowMode::Lookup => Some(cache.lookup(strands, lights, &d.lookup, progress)?),
            ShadowMode::Rays => None,
        };
        Ok(DualInputs { tables, grid, lookup })
    }
}
