//! The list of fiber models and what each says of itself: names as scene files and the CLI spell
//! them, flawed samplers, help and caption texts, and the dispatch between them.

use precompute::fiber::{
    Absorption, Fiber, FiberHit, FiberModel, FiberParams, ModelKind, SamplerKind, TableFeatures, r_width,
};
use precompute::stability::{GridPoint, params_for};
use precompute::tables::TableSettings;

// The models listed today, in the order of the list in fiber/mod.rs; a model added later comes
// after them and leaves these tests as they are.
const MODELS: [ModelKind; 4] = [ModelKind::Chiang, ModelKind::Marschner, ModelKind::Sadeghi, ModelKind::Deon2014];

#[test]
fn every_model_is_spelled_alike_by_serde_from_str_and_name() {
    assert_eq!(ModelKind::ALL[..MODELS.len()], MODELS);
    let names: Vec<&str> = MODELS.iter().map(|m| m.name()).collect();
    assert_eq!(names, ["chiang", "marschner", "sadeghi", "deon2014"]);
    for &m in ModelKind::ALL {
        assert_eq!(serde_json::to_string(&m).unwrap(), format!("\"{}\"", m.name()));
        assert_eq!(serde_json::from_str::<ModelKind>(&format!("\"{}\"", m.name())).unwrap(), m);
        assert_eq!(m.name().parse::<ModelKind>(), Ok(m));
    }
    let all: Vec<&str> = ModelKind::ALL.iter().map(|m| m.name()).collect();
    assert_eq!("hair".parse::<ModelKind>(), Err(format!("`hair`: no such fiber model ({})", all.join(", "))));
    assert_eq!(ModelKind::default(), ModelKind::Chiang);
    assert_eq!(FiberParams::default().model, ModelKind::default());
}

#[test]
fn flawed_samplers_name_their_model() {
    let flawed: Vec<_> = MODELS.iter().map(|m| m.flawed_sampler()).collect();
    assert_eq!(flawed, [None, Some("thesis"), Some("box_muller"), Some("iterative")]);
    for &model in ModelKind::ALL {
        if let Some(name) = model.flawed_sampler() {
            assert_eq!(ModelKind::with_flawed_sampler(name), Some(model));
            assert_eq!(SamplerKind::flawed(name), Some(SamplerKind::Flawed(model)));
        }
    }
    assert_eq!(ModelKind::with_flawed_sampler("importance"), None);
    assert_eq!(SamplerKind::flawed("uniform"), None);
    // The names the renderer used before the samplers moved to their models.
    assert_eq!(SamplerKind::Thesis, SamplerKind::Flawed(ModelKind::Marschner));
    assert_eq!(SamplerKind::BoxMuller, SamplerKind::Flawed(ModelKind::Sadeghi));
    assert_eq!(SamplerKind::Iterative, SamplerKind::Flawed(ModelKind::Deon2014));
    assert_eq!(ModelKind::Marschner.possessive(), "the Marschner model's (fiber.model \"marschner\")");
    assert_eq!(ModelKind::Deon2014.possessive(), "the d'Eon 2014 model's (fiber.model \"deon2014\")");
}

#[test]
fn help_and_captions_come_from_the_models() {
    let help: Vec<String> = MODELS.iter().map(|m| format!("{} ({})", m.name(), m.help())).collect();
    assert_eq!(
        help,
        [
            "chiang (Chiang et al. 2016; --beta-m, --beta-n, --alpha)",
            "marschner (Marschner et al. 2003 as Lemein 2020 uses it; --alpha-r, --beta-r)",
            "sadeghi (Sadeghi et al. 2010 as Ou et al. 2012 give it; --sadeghi-*)",
            "deon2014 (d'Eon et al. 2014; --beta-m as its roughness beta, --alpha)",
        ]
    );
    let all: Vec<String> = ModelKind::ALL.iter().map(|m| format!("{} ({})", m.name(), m.help())).collect();
    let (last, rest) = all.split_last().unwrap();
    assert_eq!(ModelKind::help_all(), format!("{} or {last}", rest.join(", ")));
    let params = |model| FiberParams { model, ..FiberParams::default() };
    let captions: Vec<String> =
        MODELS.iter().map(|&m| format!("{} lobe: {}", m.caption(), params(m).describe())).collect();
    assert_eq!(
        captions,
        [
            "Chiang fiber lobe: beta_m 0.3, beta_n 0.3, alpha 2 deg, eta 1.55",
            "Marschner fiber lobe: alpha_R -7.5 deg, beta_R 7.5 deg, eta 1.55",
            "Sadeghi lobe: alpha_R -7.5, beta_R 7.5, gamma_TT 30 deg; I 1/1/1, I_g 1",
            "d'Eon 2014 fiber lobe: beta 0.3, alpha 2 deg, eta 1.55",
        ]
    );
}

#[test]
fn the_dispatch_reaches_each_model_and_its_samplers() {
    let wo = precompute::conventions::direction(0.4, 0.0);
    let wi = precompute::conventions::direction(-0.3, 2.0);
    for &model in ModelKind::ALL {
        let params = FiberParams { model, absorption: Absorption::SigmaA([0.3; 3]), ..FiberParams::default() };
        let exact = Fiber::exact(&params).unwrap();
        assert_eq!(exact.far_field(), model.far_field(), "{model:?}");
        assert_eq!(model.far_field(), params.h_rule(1.0).len() == 1, "{model:?}");
        // Another model's flawed sampler leaves the model with its exact one.
        let others: Vec<_> = ModelKind::ALL.iter().filter(|&&o| o != model).map(|&o| SamplerKind::Flawed(o)).collect();
        for sampler in others {
            let fiber = Fiber::new(&params, sampler).unwrap();
            let (a, b) = (fiber.at(wo, 0.2), exact.at(wo, 0.2));
            for u in [[0.1, 0.2, 0.3, 0.4], [0.9, 0.7, 0.5, 0.3]] {
                let (sa, sb) = (a.sample(u).map(|s| s.wi), b.sample(u).map(|s| s.wi));
                assert_eq!(sa, sb, "{model:?} with {sampler:?}");
            }
            assert_eq!(a.eval_pdf(wi), b.eval_pdf(wi));
        }
    }
}

#[test]
fn table_features_and_grid_roughness_are_the_models() {
    // The Sadeghi model asks for at least 32 x 16 panels, an even count per half of phi.
    let sadeghi = FiberParams { model: ModelKind::Sadeghi, ..FiberParams::default() };
    let f: TableFeatures = ModelKind::Sadeghi.table_features(&sadeghi);
    assert_eq!((f.min_theta_i_panels, f.min_phi_panels, f.even_phi_panels), (32, 16, true));
    let s = TableSettings::for_fiber(&sadeghi);
    assert!(s.theta_i_panels >= 32 && s.phi_panels >= 16 && s.phi_panels.is_multiple_of(2), "{s:?}");
    assert_eq!(s.h_rule, [(0.0, 1.0)]);
    // Each model's own roughness at a grid point.
    let point = GridPoint { theta: 0.0, beta: 0.05, alpha: 3.0, mu_a: 0.5, eta: 1.6 };
    let marschner = params_for(ModelKind::Marschner, &point);
    assert_eq!((marschner.marschner.alpha_r, marschner.marschner.beta_r), (-6.0, r_width(0.05).to_degrees()));
    let sadeghi = params_for(ModelKind::Sadeghi, &point);
    assert_eq!((sadeghi.sadeghi.alpha_r, sadeghi.sadeghi.beta_r), (-3.0, 0.5 * r_width(0.05).to_degrees()));
    assert_eq!(params_for(ModelKind::Deon2014, &point).beta_m, 0.05);
    let chiang = params_for(ModelKind::Chiang, &point);
    assert!(chiang.beta_m > 0.0 && chiang.beta_m == chiang.beta_n);
    for &m in ModelKind::ALL {
        let p = params_for(m, &point);
        assert_eq!((p.model, p.eta, p.alpha, p.absorption), (m, 1.6, 3.0, Absorption::SigmaA([0.5; 3])));
        p.validate().unwrap();
    }
}
