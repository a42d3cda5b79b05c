//! The fiber material description shared by the CLI, scene files and the tables: roughness,
//! scale tilt, index of refraction, and absorption given in one of three ways.

use super::ModelKind;
use super::marschner::MarschnerParams;
use super::sadeghi::SadeghiParams;
use crate::spectrum::Rgb;
use serde::{Deserialize, Serialize};

/// Absorption of the fiber interior, per unit fiber radius, as pbrt-v3 (Pharr 2016 section 1.3.2)
/// and Blender Cycles give it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Absorption {
    /// sigma_a per color channel, given directly.
    SigmaA([f64; 3]),
    /// Pigment concentrations (Pharr 2016 section 1.5; d'Eon et al. 2011): about 8 for black,
    /// 1.3 for brown and 0.3 for blond eumelanin.
    Melanin {
        #[serde(default)]
        eumelanin: f64,
        #[serde(default)]
        pheomelanin: f64,
    },
    /// A desired diffuse-looking hair color in (0, 1] per channel, mapped through the fit of
    /// Chiang et al. 2016 (Pharr 2016 section 1.5, `SigmaAFromReflectance`).
    Color([f64; 3]),
}

/// Parameters of a single fiber. Defaults: the Chiang model, brown hair (eumelanin 1.3),
/// beta_m = beta_n = 0.3, alpha = 2 degrees, eta = 1.55. `beta_m`, `beta_n` and `alpha` are the
/// Chiang model's (d'Eon 2014 reads `beta_m` as its roughness beta, and `alpha`); the Marschner and Sadeghi
/// models read their own from `marschner` and `sadeghi`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FiberParams {
    pub model: ModelKind,
    pub absorption: Absorption,
    /// Longitudinal roughness in (0, 1].
    pub beta_m: f64,
    /// Azimuthal roughness in (0, 1].
    pub beta_n: f64,
    /// Cuticle scale tilt in degrees; positive shifts R toward the root (Blender Cycles' "Offset"
    /// has this sign; pbrt-v3/v4's code the opposite one: a pbrt scene's alpha is our -alpha).
    pub alpha: f64,
    /// Index of refraction of the fiber relative to the surrounding medium (> 1).
    pub eta: f64,
    pub marschner: MarschnerParams,
    pub sadeghi: SadeghiParams,
}

impl Default for FiberParams {
    fn default() -> Self {
        FiberParams {
            model: ModelKind::Chiang,
            absorption: Absorption::Melanin { eumelanin: 1.3, pheomelanin: 0.0 },
            beta_m: 0.3,
            beta_n: 0.3,
            alpha: 2.0,
            eta: 1.55,
            marschner: MarschnerParams::default(),
            sadeghi: SadeghiParams::default(),
        }
    }
}

/// A fiber parameter outside its valid range; the message names the field.
#[derive(Debug, thiserror::Error, PartialEq)]
#[error("fiber parameter `{field}` {problem} (got {value})")]
pub struct ParamError {
    pub field: &'static str,
    pub problem: &'static str,
    pub value: f64,
}

pub(super) fn check(field: &'static str, value: f64, ok: bool, problem: &'static str) -> Result<(), ParamError> {
    if value.is_finite() && ok { Ok(()) } else { Err(ParamError { field, problem, value }) }
}

/// Per-unit-concentration absorption of the two melanins (pbrt; Pharr 2016 section 1.5).
const EUMELANIN_SIGMA_A: [f64; 3] = [0.419, 0.697, 1.37];
const PHEOMELANIN_SIGMA_A: [f64; 3] = [0.187, 0.4, 1.05];

impl FiberParams {
    /// Checks every field; the error names the first one out of range.
    pub fn validate(&self) -> Result<(), ParamError> {
        check("beta_m", self.beta_m, self.beta_m > 0.0 && self.beta_m <= 1.0, "must be in (0, 1]")?;
        check("beta_n", self.beta_n, self.beta_n > 0.0 && self.beta_n <= 1.0, "must be in (0, 1]")?;
        check("alpha", self.alpha, self.alpha.abs() <= 20.0, "must be within +-20 degrees")?;
        check("eta", self.eta, self.eta > 1.0 && self.eta <= 4.0, "must be in (1, 4]")?;
        for model in ModelKind::ALL {
            model.validate_own(self)?;
        }
        match self.absorption {
            Absorption::SigmaA(s) => {
                for v in s {
                    check("sigma_a", v, v >= 0.0, "must be >= 0 in every channel")?;
                }
            }
            Absorption::Melanin { eumelanin, pheomelanin } => {
                check("eumelanin", eumelanin, eumelanin >= 0.0, "must be >= 0")?;
                check("pheomelanin", pheomelanin, pheomelanin >= 0.0, "must be >= 0")?;
            }
            Absorption::Color(c) => {
                for v in c {
                    check("color", v, v > 0.0 && v <= 1.0, "must be in (0, 1] in every channel")?;
                }
            }
        }
        Ok(())
    }

    /// Quadrature nodes over h for averaging the model's f over the fiber's width
    /// ([`super::Model::h_rule`]): for the Chiang model [`crate::quadrature::h_rule`] with panels
    /// `width` logistic scales wide; one node for the far-field models, whose f does not depend
    /// on h.
    pub fn h_rule(&self, width: f64) -> Vec<(f64, f64)> {
        self.model.h_rule(self, width)
    }

    /// The model's parameters, for a caption ([`super::Model::describe`]).
    pub fn describe(&self) -> String {
        self.model.describe(self)
    }

    /// The absorption coefficient per unit radius this description stands for.
    pub fn sigma_a(&self) -> Rgb {
        match self.absorption {
            Absorption::SigmaA(s) => Rgb(s),
            Absorption::Melanin { eumelanin, pheomelanin } => {
                Rgb(EUMELANIN_SIGMA_A) * eumelanin + Rgb(PHEOMELANIN_SIGMA_A) * pheomelanin
            }
            Absorption::Color(c) => {
                // Chiang et al. 2016 fit (Pharr 2016 section 1.5): sigma_a = (ln c / poly(beta_n))^2.
                let b = self.beta_n;
                let poly =
                    5.969 - 0.215 * b + 2.532 * b.powi(2) - 10.73 * b.powi(3) + 5.574 * b.powi(4) + 0.245 * b.powi(5);
                Rgb(c).map(|c| (c.ln() / poly).powi(2))
            }
        }
    }
}
