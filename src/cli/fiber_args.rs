//! Command-line flags describing a fiber, shared by every command that needs one.

use precompute::fiber::{Absorption, FiberParams, MarschnerParams, ModelKind, ParamError, SadeghiParams};

/// Fiber material flags. Absorption comes from exactly one of --sigma-a, --eumelanin/--pheomelanin
/// or --color; with none of them the hair is brown (eumelanin 1.3).
#[derive(clap::Args, Debug, Clone)]
pub struct FiberArgs {
    /// Absorption coefficient per unit fiber radius, "R,G,B" (or one value for all channels).
    #[arg(long, value_name = "R,G,B", value_parser = parse_rgb, allow_hyphen_values = true, conflicts_with_all = ["eumelanin", "pheomelanin", "color"])]
    pub sigma_a: Option<[f64; 3]>,
    /// Eumelanin concentration: about 0.3 blond, 1.3 brown, 8 black.
    #[arg(long, value_name = "C", conflicts_with = "color", allow_negative_numbers = true)]
    pub eumelanin: Option<f64>,
    /// Pheomelanin concentration (red hair).
    #[arg(long, value_name = "C", conflicts_with = "color", allow_negative_numbers = true)]
    pub pheomelanin: Option<f64>,
    /// Desired hair color "R,G,B" in (0, 1], mapped to absorption by the Chiang et al. 2016 fit.
    #[arg(long, value_name = "R,G,B", value_parser = parse_rgb, allow_hyphen_values = true)]
    pub color: Option<[f64; 3]>,
    /// Longitudinal roughness in (0, 1].
    #[arg(long, default_value_t = 0.3, allow_negative_numbers = true)]
    pub beta_m: f64,
    /// Azimuthal roughness in (0, 1].
    #[arg(long, default_value_t = 0.3, allow_negative_numbers = true)]
    pub beta_n: f64,
    /// Cuticle scale tilt in degrees (negative allowed; positive puts R toward the root, as Cycles'
    /// Offset does; pbrt-v3/v4 use the opposite sign).
    #[arg(long, default_value_t = 2.0, allow_negative_numbers = true)]
    pub alpha: f64,
    /// Index of refraction of the fiber (> 1).
    #[arg(long, default_value_t = 1.55, allow_negative_numbers = true)]
    pub eta: f64,
    /// Fiber scattering model (the list comes from the models themselves).
    #[arg(long, default_value = "chiang", help = format!("Fiber scattering model: {}", ModelKind::help_all()))]
    pub model: ModelKind,
    /// Marschner: longitudinal shift of the R lobe in degrees (negative puts R toward the root).
    #[arg(long, default_value_t = MarschnerParams::default().alpha_r, allow_negative_numbers = true)]
    pub alpha_r: f64,
    /// Marschner: longitudinal width of the R lobe in degrees.
    #[arg(long, default_value_t = MarschnerParams::default().beta_r, allow_negative_numbers = true)]
    pub beta_r: f64,
    /// Sadeghi: longitudinal shift of the R lobe in degrees (negative puts R toward the root).
    #[arg(long, default_value_t = SadeghiParams::default().alpha_r, allow_negative_numbers = true)]
    pub sadeghi_alpha_r: f64,
    /// Sadeghi: longitudinal width of the R lobe in degrees (TT's is half of it, TRT's twice).
    #[arg(long, default_value_t = SadeghiParams::default().beta_r, allow_negative_numbers = true)]
    pub sadeghi_beta_r: f64,
    /// Sadeghi: azimuthal width of the TT lobe in degrees.
    #[arg(long, default_value_t = SadeghiParams::default().gamma_tt, allow_negative_numbers = true)]
    pub sadeghi_gamma_tt: f64,
    /// Sadeghi: scales of the R, TT and TRT lobes' energies, "R,TT,TRT" (1: what a smooth fiber of
    /// this absorption scatters at normal incidence).
    #[arg(long, value_name = "R,TT,TRT", value_parser = parse_rgb, default_value = "1,1,1", allow_hyphen_values = true)]
    pub sadeghi_intensity: [f64; 3],
    /// Sadeghi: glint peak relative to the TRT lobe's.
    #[arg(long, default_value_t = SadeghiParams::default().i_g, allow_negative_numbers = true)]
    pub sadeghi_glint: f64,
}

impl FiberArgs {
    /// The validated fiber description these flags stand for.
    pub fn params(&self) -> Result<FiberParams, ParamError> {
        let absorption = match (self.sigma_a, self.eumelanin, self.pheomelanin, self.color) {
            (Some(s), ..) => Absorption::SigmaA(s),
            (_, None, None, Some(c)) => Absorption::Color(c),
            (_, None, None, None) => FiberParams::default().absorption,
            (_, e, p, _) => Absorption::Melanin { eumelanin: e.unwrap_or(0.0), pheomelanin: p.unwrap_or(0.0) },
        };
        let params = FiberParams {
            model: self.model,
            absorption,
            beta_m: self.beta_m,
            beta_n: self.beta_n,
            alpha: self.alpha,
            eta: self.eta,
            marschner: MarschnerParams { alpha_r: self.alpha_r, beta_r: self.beta_r, ..MarschnerParams::default() },
            sadeghi: SadeghiParams {
                alpha_r: self.sadeghi_alpha_r,
                beta_r: self.sadeghi_beta_r,
                gamma_tt: self.sadeghi_gamma_tt,
                i_r: self.sadeghi_intensity[0],
                i_tt: self.sadeghi_intensity[1],
                i_trt: self.sadeghi_intensity[2],
                i_g: self.sadeghi_glint,
                ..SadeghiParams::default()
            },
        };
        params.validate()?;
        Ok(params)
    }
}

/// Parses "R,G,B" or a single value for all three channels.
fn parse_rgb(s: &str) -> Result<[f64; 3], String> {
    let values: Vec<f64> = s
        .split(',')
        .map(|v| v.trim().parse::<f64>().map_err(|e| format!("`{v}` is not a number: {e}")))
        .collect::<Result<_, _>>()?;
    match values[..] {
        [v] => Ok([v; 3]),
        [r, g, b] => Ok([r, g, b]),
        _ => Err(format!("expected R,G,B or one value, got {} values", values.len())),
    }
}
