//! What makes a fiber model a model of this crate: the [`Model`] trait, which each model's file
//! implements with everything particular to it (its name, parameters, samplers, how the tables
//! and the stability grid size and set it), and the [`models!`] list that turns the models into
//! [`super::ModelKind`], [`super::Fiber`] and [`super::FiberAt`].
//!
//! Adding a model: its own file under `fiber/` with the model, its hit and `impl Model`, and one
//! line in the `models!` list in `fiber/mod.rs`. A model with parameters of its own beyond those
//! every model shares also needs a field in [`FiberParams`] (its key in scene files' `fiber`).

use super::{FiberModel, FiberParams, ParamError};

/// A single-fiber scattering model, as the rest of the crate and the renderer see it. Everything
/// here is asked through [`super::ModelKind`] (which dispatches to the model a [`FiberParams`]
/// names) or [`super::Fiber`]; nothing outside a model's file matches on models.
pub trait Model: FiberModel + Sized {
    /// The model's name as scene files (`fiber.model`) and the CLI (`--model`) spell it; the same
    /// as `ModelKind`'s serde spelling (snake_case of its variant).
    const NAME: &'static str;
    /// One line for `--model`'s help: where the model comes from and which parameters it reads.
    const HELP: &'static str;
    /// The model as sentences name it: "the {TITLE} model".
    const TITLE: &'static str;
    /// What a chart calls one fiber of it: "{CAPTION} lobe, light at ...".
    const CAPTION: &'static str;
    /// Whether the model is far-field: f does not depend on the hit's offset h, so one hit serves
    /// every h and one h node averages over the fiber's width.
    const FAR_FIELD: bool;
    /// The stability report's label for the model with its exact sampler, MODEL-SAMPLER.
    const EXACT_LABEL: &'static str;
    /// The flawed sampler the model's source publishes, kept to measure the flaw; `None` if none.
    const FLAWED: Option<FlawedSampler> = None;

    /// The model of `params`, drawing with its flawed sampler when `flawed` (and it has one), else
    /// with its exact one.
    fn build(params: &FiberParams, flawed: bool) -> Result<Self, ParamError>;

    /// Checks the parameters of `params` that are the model's own (its own section of a scene
    /// file's `fiber`); [`FiberParams::validate`] asks every model, whichever `params` names.
    fn validate_own(_params: &FiberParams) -> Result<(), ParamError> {
        Ok(())
    }

    /// Quadrature nodes over h averaging the model's f over the fiber's width (weights summing to
    /// 1); `width` scales a near-field model's panels. A far-field model needs one node.
    fn h_rule(_params: &FiberParams, _width: f64) -> Vec<(f64, f64)> {
        vec![(0.0, 1.0)]
    }

    /// The narrowest features of the model's f with `params`, which size the quadrature of the
    /// precomputed dual-scattering tables.
    fn table_features(params: &FiberParams) -> TableFeatures;

    /// Sets the model's own roughness (and tilt, where it has its own) in `params` so that its R
    /// lobe is as wide as that of a rough cylinder of Beckmann roughness `beta` ([`r_width`]) and
    /// its tilt is `params.alpha`: a point of d'Eon, Marschner and Hanika 2014's parameter grid
    /// (section 2.1), whose eta, absorption and tilt `params` already holds.
    fn set_grid_roughness(params: &mut FiberParams, beta: f64);

    /// The model's parameters in `params`, for a caption: "beta_m 0.3, beta_n 0.3, ...".
    fn describe(params: &FiberParams) -> String;
}

/// A model's deliberately flawed sampler: the one its source publishes, whose reported density
/// is not the density it draws with (or which draws from the wrong distribution).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FlawedSampler {
    /// Its name as the CLI and scene files spell it (`render.sampling`, `--sampling`).
    pub name: &'static str,
    /// The stability report's label for the model with it, MODEL-SAMPLER.
    pub label: &'static str,
    /// What it is, one line, for help texts.
    pub help: &'static str,
}

/// The narrowest features of a model's f, which size the tables' quadrature
/// (`tables::TableSettings::for_fiber`, through `TableSettings::for_roughness`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TableFeatures {
    /// The azimuthal logistic scale s of the narrowest azimuthal feature.
    pub scale: f64,
    /// The longitudinal variance v (radians^2) whose standard deviation sizes the theta_i panels
    /// (1.5 sqrt(v) wide): for the Chiang model the v of beta_m, three standard deviations of its
    /// narrowest lobe, TT (variance v/4).
    pub variance: f64,
    /// At least this many theta_i panels.
    pub min_theta_i_panels: usize,
    /// At least this many phi panels per half.
    pub min_phi_panels: usize,
    /// Whether the phi panels per half must be even (panel edges at phi = 0 and pi).
    pub even_phi_panels: bool,
}

impl TableFeatures {
    /// Features of azimuthal scale `scale` and longitudinal variance `variance`, with no other
    /// demand on the panels.
    pub fn new(scale: f64, variance: f64) -> TableFeatures {
        TableFeatures { scale, variance, min_theta_i_panels: 0, min_phi_panels: 0, even_phi_panels: false }
    }
}

/// The longitudinal standard deviation (radians) of the R lobe of a rough cylinder of Beckmann
/// roughness `beta` at normal incidence: sqrt(v_R) = beta sqrt(2) (d'Eon, Marschner and Hanika
/// 2014, eq. 6 at h = 0). [`Model::set_grid_roughness`] gives each model's R lobe this width.
pub fn r_width(beta: f64) -> f64 {
    std::f64::consts::SQRT_2 * beta
}

/// Declares the fiber models from one list, `Variant => module::Type`, each `Type` implementing
/// [`Model`] in `fiber/module.rs`: the modules (their public items re-exported), the enum
/// [`super::ModelKind`] naming them (serde and `FromStr` spell each [`Model::NAME`]), the enums
/// [`super::Fiber`] and [`super::FiberAt`] holding one of them, and the static dispatch between.
/// The first model listed is the default.
macro_rules! models {
    ($($variant:ident => $module:ident :: $model:ident),+ $(,)?) => {
        $(
            mod $module;
            pub use $module::*;
        )+

        /// The single-fiber scattering model a [`FiberParams`] names, spelled [`ModelKind::name`]
        /// in scene files and on the command line. Each is a type implementing [`Model`].
        #[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize, serde::Deserialize)]
        #[serde(rename_all = "snake_case")]
        pub enum ModelKind {
            $(
                #[doc = concat!("[`", stringify!($model), "`].")]
                $variant,
            )+
        }

        impl ModelKind {
            /// Every model, in the order of the list in `fiber/mod.rs`.
            pub const ALL: &'static [ModelKind] = &[$(ModelKind::$variant),+];

            /// The name scene files and the CLI spell it with ([`Model::NAME`]).
            pub const fn name(self) -> &'static str {
                match self {
                    $(ModelKind::$variant => <$model as Model>::NAME,)+
                }
            }

            /// One line on the model for `--model`'s help ([`Model::HELP`]).
            pub const fn help(self) -> &'static str {
                match self {
                    $(ModelKind::$variant => <$model as Model>::HELP,)+
                }
            }

            /// The model as sentences name it ([`Model::TITLE`]): "Marschner", "d'Eon 2014".
            pub const fn title(self) -> &'static str {
                match self {
                    $(ModelKind::$variant => <$model as Model>::TITLE,)+
                }
            }

            /// What a chart calls one fiber of it ([`Model::CAPTION`]).
            pub const fn caption(self) -> &'static str {
                match self {
                    $(ModelKind::$variant => <$model as Model>::CAPTION,)+
                }
            }

            /// Whether f does not depend on the offset h ([`Model::FAR_FIELD`]).
            pub const fn far_field(self) -> bool {
                match self {
                    $(ModelKind::$variant => <$model as Model>::FAR_FIELD,)+
                }
            }

            /// The stability report's label of the model with its exact sampler.
            pub const fn exact_label(self) -> &'static str {
                match self {
                    $(ModelKind::$variant => <$model as Model>::EXACT_LABEL,)+
                }
            }

            /// The model's flawed sampler, if it has one ([`Model::FLAWED`]).
            pub const fn flawed(self) -> Option<FlawedSampler> {
                match self {
                    $(ModelKind::$variant => <$model as Model>::FLAWED,)+
                }
            }

            /// The model's parameters in `params`, for a caption ([`Model::describe`]).
            pub fn describe(self, params: &FiberParams) -> String {
                match self {
                    $(ModelKind::$variant => <$model as Model>::describe(params),)+
                }
            }

            /// The table features of the model with `params` ([`Model::table_features`]).
            pub fn table_features(self, params: &FiberParams) -> TableFeatures {
                match self {
                    $(ModelKind::$variant => <$model as Model>::table_features(params),)+
                }
            }

            /// Sets the model's roughness in `params` for a point of the stability grid
            /// ([`Model::set_grid_roughness`]).
            pub fn set_grid_roughness(self, params: &mut FiberParams, beta: f64) {
                match self {
                    $(ModelKind::$variant => <$model as Model>::set_grid_roughness(params, beta),)+
                }
            }

            pub(crate) fn h_rule(self, params: &FiberParams, width: f64) -> Vec<(f64, f64)> {
                match self {
                    $(ModelKind::$variant => <$model as Model>::h_rule(params, width),)+
                }
            }

            pub(crate) fn validate_own(self, params: &FiberParams) -> Result<(), ParamError> {
                match self {
                    $(ModelKind::$variant => <$model as Model>::validate_own(params),)+
                }
            }
        }

        /// The fiber model a [`FiberParams`] names: what commands and integrators hold, so that
        /// none of them asks which model it is.
        pub enum Fiber {
            $($variant($model),)+
        }

        /// A [`Fiber`] at one hit.
        pub enum FiberAt<'a> {
            $($variant(<$model as FiberModel>::Hit<'a>),)+
        }

        impl Fiber {
            /// The model of `params` drawing with `sampler`.
            pub fn new(params: &FiberParams, sampler: SamplerKind) -> Result<Fiber, ParamError> {
                Ok(match params.model {
                    $(ModelKind::$variant => Fiber::$variant(<$model as Model>::build(
                        params,
                        sampler == SamplerKind::Flawed(ModelKind::$variant),
                    )?),)+
                })
            }

            /// Whether the model is far-field ([`Model::FAR_FIELD`]): f does not depend on the
            /// hit's offset h, so one hit serves every h.
            pub fn far_field(&self) -> bool {
                match self {
                    $(Fiber::$variant(_) => <$model as Model>::FAR_FIELD,)+
                }
            }
        }

        impl FiberModel for Fiber {
            type Hit<'a> = FiberAt<'a>;

            fn at(&self, wo: DVec3, h: f64) -> FiberAt<'_> {
                match self {
                    $(Fiber::$variant(m) => FiberAt::$variant(m.at(wo, h)),)+
                }
            }

            fn eval_h_average(&self, wo: DVec3, rule: &[(f64, f64)], wis: &[DVec3], out: &mut [Rgb]) {
                match self {
                    $(Fiber::$variant(m) => m.eval_h_average(wo, rule, wis, out),)+
                }
            }
        }

        impl FiberHit for FiberAt<'_> {
            fn eval(&self, wi: DVec3) -> Rgb {
                match self {
                    $(FiberAt::$variant(h) => h.eval(wi),)+
                }
            }

            fn sample(&self, u: [f64; 4]) -> Option<FiberSample> {
                match self {
                    $(FiberAt::$variant(h) => h.sample(u),)+
                }
            }

            fn eval_pdf(&self, wi: DVec3) -> (Rgb, f64) {
                match self {
                    $(FiberAt::$variant(h) => h.eval_pdf(wi),)+
                }
            }

            fn pdf(&self, wi: DVec3) -> f64 {
                match self {
                    $(FiberAt::$variant(h) => h.pdf(wi),)+
                }
            }
        }

        impl SpreadHit for FiberAt<'_> {
            fn eval_spread(&self, wi: DVec3, spread: Rgb) -> Rgb {
                match self {
                    $(FiberAt::$variant(h) => h.eval_spread(wi, spread),)+
                }
            }

            fn eval_both(&self, wi: DVec3, spread: Rgb) -> (Rgb, Rgb) {
                match self {
                    $(FiberAt::$variant(h) => h.eval_both(wi, spread),)+
                }
            }
        }
    };
}

pub(super) use models;
