//! The stability survey (`dualhair stability`): every fiber model with every sampler over the parameter grid of d'Eon,
//! Marschner and Hanika 2014
//! section 2.1 (extended to grazing theta = 1.5707), measured where methods are known to fail:
//! NaN/Inf, negative values, albedo (the white furnace), the reported density's integral, the
//! agreement of each sample with `eval_pdf`, importance- against uniform-sampled estimates, and
//! the distance of each model's lobe from the rough-cylinder simulation (`fibersim`).

use crate::analysis::plot::{CellMap, CellScale, HeatMap, heat_maps};
use crate::error::{Context, Result, bail};
use crate::output::write_atomically;
use crate::output::write_png;
use crate::progress::Progress;
use precompute::fibersim::FiberSim;
use precompute::stability::{
    Estimates, GridPoint, Health, Method, estimates, health, lobe_distance, lobe_histogram, params_for,
};
use rayon::prelude::*;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Runs every model x sampler over d'Eon, Marschner and Hanika 2014's parameter grid and writes where each fails: a CSV
/// per part and a heat map per measure (PNG), with a summary.md, into the output folder.
///
/// The full grid (theta_i x alpha x mu_a x beta x eta, 16,800 points per method) is checked for
/// NaN/Inf, negative values, samples disagreeing with eval_pdf and failed draws. Three slices
/// through it (theta_i x beta; theta_i x mu_a and theta_i x alpha at beta = 0.04) get the
/// integrals: albedo, pdf integral, the method's own estimate against the albedo and against
/// uniform sampling, and (theta_i x beta) the distance to the Monte Carlo rough-cylinder
/// simulation. Takes about ten minutes on two cores with the defaults.
#[derive(Debug)]
pub struct StabilitySettings {
    /// Output folder (created if missing).
    pub output: PathBuf,
    /// Directions per estimate at each point of the slices.
    pub samples: usize,
    /// Rays of the rough-cylinder simulation per point of the beta slice (split into two halves
    /// whose distance is the noise floor; a quarter as many samples of each model), and of each
    /// model and the simulation at the four points drawn side by side; 0 skips the comparison.
    pub rays: u64,
    /// Offsets h per point of the full grid, each with 8 random directions and 8 samples.
    pub hits: usize,
    /// Every third value of each grid axis only (a quick look; tests use it).
    pub quick: bool,
    /// Seed of every random number drawn.
    pub seed: u64,
    /// Worker threads (default: all cores).
    pub threads: Option<usize>,
}

/// d'Eon, Marschner and Hanika 2014 section 2.1's grid, with theta_i extended to 1.5707 (grazing, about 1e-4 short of
/// pi/2: written as such so that it prints as it reads).
#[allow(clippy::approx_constant)]
const THETAS: [f64; 12] = [0.0, 0.25, 0.5, 0.75, 1.0, 1.1, 1.2, 1.3, 1.4, 1.5, 1.55, 1.5707];
const ALPHAS: [f64; 5] = [-4.0, -2.0, 0.0, 2.0, 4.0];
const MU_AS: [f64; 14] = [0.0, 0.003, 0.006, 0.015, 0.03, 0.06, 0.12, 0.25, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0];
const BETAS: [f64; 10] = [0.0025, 0.005, 0.01, 0.02, 0.03, 0.04, 0.06, 0.08, 0.15, 0.3];
const ETAS: [f64; 2] = [1.55, 1.55 / 1.33];

/// The slices' fixed values: d'Eon, Marschner and Hanika 2014's figures use beta = 0.04.
const SLICE_BETA: f64 = 0.04;
const BASE: GridPoint = GridPoint { theta: 0.0, beta: SLICE_BETA, alpha: 0.0, mu_a: 0.0, eta: 1.55 };

/// Lat-long resolution of the simulation comparison (d'Eon, Marschner and Hanika 2014 binned 400 x 100; coarser bins
/// leave less noise in the distance for the rays affordable at every grid point).
const SIM_SIZE: (usize, usize) = (120, 60);

/// A slice: theta_i (rows) against one other axis (columns).
struct Slice {
    name: &'static str,
    axis: &'static str,
    values: Vec<f64>,
    set: fn(&mut GridPoint, f64),
}

fn every_third(values: &[f64], quick: bool) -> Vec<f64> {
    values.iter().copied().enumerate().filter(|(i, _)| !quick || i % 3 == 0).map(|(_, v)| v).collect()
}

/// One row of slices.csv.
struct SliceRow {
    slice: &'static str,
    method: Method,
    point: GridPoint,
    est: Estimates,
    /// Distance of the model's lobe to the simulation's, and the simulation's own noise floor.
    sim: Option<(f64, f64)>,
}

impl SliceRow {
    /// The method's own estimate relative to the albedo, minus 1.
    fn importance_bias(&self) -> f64 {
        self.est.importance.mean / self.est.albedo.mean - 1.0
    }

    /// [`SliceRow::importance_bias`] in standard errors of the difference.
    fn importance_bias_z(&self) -> f64 {
        let (i, a) = (self.est.importance, self.est.albedo);
        (i.mean - a.mean) / (i.se * i.se + a.se * a.se).sqrt()
    }

    /// The difference of the method's own and the uniform estimate in standard errors.
    fn importance_vs_uniform(&self) -> f64 {
        let (i, u) = (self.est.importance, self.est.uniform);
        (i.mean - u.mean) / (i.se * i.se + u.se * u.se).sqrt()
    }
}

/// Runs the survey into `args.output` and returns its summary; reports grid points done to
/// `progress`.
pub fn run(args: &StabilitySettings, progress: &dyn Progress) -> Result<String> {
    if args.samples < 2 || args.samples > 100_000_000 {
        bail!("--samples must be between 2 and 1e8, got {}", args.samples);
    }
    if !(1..=1000).contains(&args.hits) {
        bail!("--hits must be between 1 and 1000, got {}", args.hits);
    }
    if args.rays > precompute::fibersim::MAX_RAYS {
        bail!("--rays must be at most 1e9, got {}", args.rays);
    }
    std::fs::create_dir_all(&args.output)
        .with_context(|| format!("{}: cannot create the folder", args.output.display()))?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads.unwrap_or(0))
        .build()
        .context("cannot start the worker threads")?;
    let thetas = every_third(&THETAS, args.quick);
    let slices = [
        Slice { name: "beta", axis: "roughness beta", values: every_third(&BETAS, args.quick), set: |p, v| p.beta = v },
        Slice {
            name: "mu_a",
            axis: "absorption mu_a (per radius)",
            values: every_third(&MU_AS, args.quick),
            set: |p, v| p.mu_a = v,
        },
        Slice {
            name: "alpha",
            axis: "scale tilt alpha (degrees)",
            values: every_third(&ALPHAS, args.quick),
            set: |p, v| p.alpha = v,
        },
    ];
    let grid = full_grid(args.quick, &thetas);
    let slice_points: Vec<(&Slice, GridPoint)> = slices
        .iter()
        .flat_map(|s| {
            thetas.iter().flat_map(move |&theta| {
                s.values.iter().map(move |&v| {
                    let mut p = GridPoint { theta, ..BASE };
                    (s.set)(&mut p, v);
                    (s, p)
                })
            })
        })
        .collect();
    let bar = progress.task("grid points", Some((grid.len() + slice_points.len()) as u64));
    let (health_rows, slice_rows) = pool.install(|| -> Result<_> {
        let health_rows = grid
            .par_iter()
            .enumerate()
            .map(|(i, p)| {
                let row = Method::ALL
                    .iter()
                    .map(|m| {
                        let (fiber, _) = m.fibers(p)?;
                        Ok(health(&fiber, p.theta, args.hits, 8, args.seed ^ (i as u64).wrapping_mul(0x9E37_79B9)))
                    })
                    .collect::<Result<Vec<Health>>>();
                bar.advance(1);
                row
            })
            .collect::<Result<Vec<_>>>()?;
        let slice_rows = slice_points
            .par_iter()
            .enumerate()
            .map(|(i, (slice, p))| {
                let seed = args.seed.wrapping_add(1 + i as u64).wrapping_mul(0x2545_F491_4F6C_DD1D);
                let rows = measure(slice.name, p, args, seed);
                bar.advance(1);
                rows
            })
            .collect::<Result<Vec<_>>>()?;
        Ok((health_rows, slice_rows.into_iter().flatten().collect::<Vec<_>>()))
    })?;
    drop(bar);

    if args.rays > 0 {
        pool.install(|| lobes(&args.output.join("lobes"), args))?;
    }
    write_grid_csv(&args.output.join("grid.csv"), &grid, &health_rows)?;
    write_slices_csv(&args.output.join("slices.csv"), &slice_rows)?;
    charts(&args.output, &thetas, &slices, &slice_rows, &grid, &health_rows)?;
    let summary = summary(args, &grid, &health_rows, &slice_rows);
    write_atomically(&args.output.join("summary.md"), |tmp| Ok(std::fs::write(tmp, &summary)?))?;
    Ok(format!("{summary}\nwrote {}", args.output.display()))
}

/// Every point of the grid (every third value of each axis with `quick`).
fn full_grid(quick: bool, thetas: &[f64]) -> Vec<GridPoint> {
    let mut out = Vec::new();
    for &theta in thetas {
        for &alpha in &every_third(&ALPHAS, quick) {
            for &mu_a in &every_third(&MU_AS, quick) {
                for &beta in &every_third(&BETAS, quick) {
                    for &eta in &ETAS {
                        out.push(GridPoint { theta, beta, alpha, mu_a, eta });
                    }
                }
            }
        }
    }
    out
}

/// Every method's estimates at one slice point, and on the beta slice each model's distance to
/// the simulation (the costliest measure: a quarter as many model samples as simulated rays, per
/// model).
fn measure(slice: &'static str, p: &GridPoint, args: &StabilitySettings, seed: u64) -> Result<Vec<SliceRow>> {
    // The simulation in two halves: their distance is its noise floor, their mean the reference.
    let sim = if args.rays > 0 && slice == "beta" {
        let params = params_for(precompute::fiber::ModelKind::Deon2014, p);
        let fs = FiberSim::new(&params, p.theta)?;
        let half = (args.rays / 2).max(1);
        let (w, h) = SIM_SIZE;
        let a = fs.simulate(half, seed, w, h, &mut |_| {})?.total_image();
        let b = fs.simulate(half, seed ^ 0x5555, w, h, &mut |_| {})?.total_image();
        let floor = lobe_distance(&a, &b);
        let mut mean = a;
        mean.pixels.iter_mut().zip(&b.pixels).for_each(|(x, y)| *x = (*x + *y) * 0.5);
        Some((mean, floor))
    } else {
        None
    };
    let mut rows: Vec<SliceRow> = Vec::new();
    for m in &Method::ALL {
        let (fiber, exact) = m.fibers(p)?;
        let est = estimates(&fiber, &exact, p.theta, args.samples, seed);
        // The lobe is the model's: methods of one model share its distance.
        let same_model = rows.iter().find(|r| r.method.model == m.model).map(|r| r.sim);
        let sim = match (same_model, &sim) {
            (Some(known), _) => known,
            (None, Some((image, floor))) => {
                let (w, h) = SIM_SIZE;
                let model = lobe_histogram(&exact, p.theta, (args.rays / 4) as usize, seed, w, h);
                Some((lobe_distance(&model, image), *floor))
            }
            (None, None) => None,
        };
        rows.push(SliceRow { slice, method: *m, point: *p, est, sim });
    }
    Ok(rows)
}

/// Points where the lobes are drawn beside the simulation: the paper's figures' roughnesses and
/// absorptions (d'Eon, Marschner and Hanika 2014 figures 3-5), from a near-normal to a grazing light.
const LOBE_POINTS: [GridPoint; 4] = [
    GridPoint { theta: 0.5, beta: 0.04, alpha: 2.0, mu_a: 0.25, eta: 1.55 },
    GridPoint { theta: 1.1, beta: 0.06, alpha: 2.0, mu_a: 0.12, eta: 1.55 },
    GridPoint { theta: 1.4, beta: 0.15, alpha: 0.0, mu_a: 0.5, eta: 1.55 },
    GridPoint { theta: 0.25, beta: 0.3, alpha: -2.0, mu_a: 0.0, eta: 1.55 },
];

/// Each model's h-averaged lobe binned beside the simulation's, on one color scale, at
/// [`LOBE_POINTS`] (`lobes/N.png`), from `args.rays` rays and as many model samples.
fn lobes(dir: &Path, args: &StabilitySettings) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("{}: cannot create the folder", dir.display()))?;
    let (w, h) = (200, 100);
    for (k, p) in LOBE_POINTS.iter().enumerate() {
        let sim = FiberSim::new(&params_for(precompute::fiber::ModelKind::Deon2014, p), p.theta)?
            .simulate(args.rays, args.seed, w, h, &mut |_| {})?
            .total_image();
        let mut images = vec![("rough-cylinder simulation (fibersim)".to_string(), sim)];
        for m in Method::ALL.iter().filter(|m| m.sampler == precompute::fiber::SamplerKind::Exact) {
            let (_, exact) = m.fibers(p)?;
            let image = lobe_histogram(&exact, p.theta, args.rays as usize, args.seed, w, h);
            let d = lobe_distance(&image, &images[0].1);
            images.push((format!("{:?} (distance {d:.2})", m.model), image));
        }
        let values: Vec<Vec<f64>> =
            images.iter().map(|(_, i)| i.pixels.iter().map(|p| p.luminance()).collect()).collect();
        let maps: Vec<HeatMap> = images
            .iter()
            .zip(&values)
            .map(|((name, _), v)| HeatMap::lat_long(name, "luminance, h-averaged f cos (1/sr)", w, h, v))
            .collect();
        let title = format!(
            "lobes binned {w}x{h}, light at theta_i = {}: beta {}, alpha {} deg, mu_a {}, eta {}",
            p.theta, p.beta, p.alpha, p.mu_a, p.eta
        );
        write_png(&dir.join(format!("{}.png", k + 1)), &heat_maps(&title, &maps, 4.0, 3)?)?;
    }
    Ok(())
}

fn write_grid_csv(path: &Path, grid: &[GridPoint], rows: &[Vec<Health>]) -> Result<()> {
    let mut csv =
        String::from("method,theta,beta,alpha,mu_a,eta,values,non_finite,negative,inconsistent,no_direction\n");
    for (p, row) in grid.iter().zip(rows) {
        for (m, h) in Method::ALL.iter().zip(row) {
            if h.non_finite + h.negative + h.inconsistent + h.no_direction == 0 {
                continue;
            }
            writeln!(
                csv,
                "{},{},{},{},{},{:.6},{},{},{},{},{}",
                m.name(),
                p.theta,
                p.beta,
                p.alpha,
                p.mu_a,
                p.eta,
                h.values,
                h.non_finite,
                h.negative,
                h.inconsistent,
                h.no_direction
            )?;
        }
    }
    write_atomically(path, |tmp| Ok(std::fs::write(tmp, &csv)?))
}

fn write_slices_csv(path: &Path, rows: &[SliceRow]) -> Result<()> {
    let mut csv = String::from(
        "slice,method,theta,beta,alpha,mu_a,eta,albedo,albedo_se,pdf_integral,pdf_integral_se,importance,importance_se,uniform,uniform_se,importance_bias,importance_bias_z,importance_vs_uniform_z,fibersim_distance,fibersim_floor\n",
    );
    for r in rows {
        let (d, floor) = r.sim.map_or((String::new(), String::new()), |(d, f)| (format!("{d:.5}"), format!("{f:.5}")));
        let e = &r.est;
        writeln!(
            csv,
            "{},{},{},{},{},{},{:.6},{:.6e},{:.3e},{:.6e},{:.3e},{:.6e},{:.3e},{:.6e},{:.3e},{:.5},{:.3},{:.3},{d},{floor}",
            r.slice,
            r.method.name(),
            r.point.theta,
            r.point.beta,
            r.point.alpha,
            r.point.mu_a,
            r.point.eta,
            e.albedo.mean,
            e.albedo.se,
            e.pdf_integral.mean,
            e.pdf_integral.se,
            e.importance.mean,
            e.importance.se,
            e.uniform.mean,
            e.uniform.se,
            r.importance_bias(),
            r.importance_bias_z(),
            r.importance_vs_uniform(),
        )?;
    }
    write_atomically(path, |tmp| Ok(std::fs::write(tmp, &csv)?))
}

/// A measure drawn per slice: its file name, title, color scale and cell format.
struct Measure {
    name: &'static str,
    title: &'static str,
    scale: CellScale,
    value: fn(&SliceRow) -> f64,
    /// Whether it is a property of the model (drawn once per model, not per sampler).
    per_model: bool,
}

const MEASURES: [Measure; 5] = [
    Measure {
        name: "albedo",
        title: "albedo: integral of f cos over the sphere (h-averaged; 1 = energy conserving when mu_a = 0)",
        scale: CellScale::Linear { lo: 0.0, hi: 1.2 },
        value: |r| r.est.albedo.mean,
        per_model: true,
    },
    Measure {
        name: "pdf_integral",
        title: "integral of the reported pdf minus 1 (0 = normalized)",
        scale: CellScale::Diverging { limit: 0.2 },
        value: |r| r.est.pdf_integral.mean - 1.0,
        per_model: false,
    },
    Measure {
        name: "importance_bias",
        title: "method's estimate / albedo - 1 (0 = unbiased; noise in summary.md and slices.csv)",
        scale: CellScale::Diverging { limit: 0.2 },
        value: SliceRow::importance_bias,
        per_model: false,
    },
    Measure {
        name: "importance_vs_uniform",
        title: "method's estimate minus uniform sampling's, in standard errors (|z| > 4: disagree)",
        scale: CellScale::Diverging { limit: 8.0 },
        value: SliceRow::importance_vs_uniform,
        per_model: false,
    },
    Measure {
        name: "fibersim_distance",
        title: "relative L1 distance of the model's lobe to the rough-cylinder simulation (0 = same, 2 = disjoint)",
        scale: CellScale::Linear { lo: 0.0, hi: 1.0 },
        value: |r| r.sim.map_or(f64::NAN, |(d, _)| d),
        per_model: true,
    },
];

fn charts(
    dir: &Path,
    thetas: &[f64],
    slices: &[Slice],
    rows: &[SliceRow],
    grid: &[GridPoint],
    health: &[Vec<Health>],
) -> Result<()> {
    let y_ticks: Vec<String> = thetas.iter().map(|t| format!("{t}")).collect();
    for slice in slices {
        let x_ticks: Vec<String> = slice.values.iter().map(|v| format!("{v}")).collect();
        for measure in &MEASURES {
            if measure.name == "fibersim_distance"
                && rows.iter().filter(|r| r.slice == slice.name).all(|r| r.sim.is_none())
            {
                continue;
            }
            let panels: Vec<(String, Vec<f64>)> = Method::ALL
                .iter()
                .filter(|m| !measure.per_model || Method::ALL.iter().find(|o| o.model == m.model) == Some(m))
                .map(|m| {
                    let name = if measure.per_model { format!("{:?}", m.model) } else { m.name().to_string() };
                    let mut values = Vec::new();
                    for &theta in thetas {
                        for &v in &slice.values {
                            let r = rows.iter().find(|r| {
                                r.slice == slice.name && r.method == *m && r.point.theta == theta && {
                                    let mut p = GridPoint { theta, ..BASE };
                                    (slice.set)(&mut p, v);
                                    r.point == p
                                }
                            });
                            values.push(r.map_or(f64::NAN, measure.value));
                        }
                    }
                    (name, values)
                })
                .collect();
            let title = format!("{} (theta_i vs {})", measure.title, slice.axis);
            let format = |v: f64| if v.abs() >= 100.0 { format!("{v:.0}") } else { format!("{v:.2}") };
            CellMap {
                title: &title,
                x_label: slice.axis,
                y_label: "theta_i (rad)",
                x_ticks: &x_ticks,
                y_ticks: &y_ticks,
                panels: &panels,
                scale: measure.scale,
                format: &format,
            }
            .write(&dir.join(format!("{}_{}.png", slice.name, measure.name)))?;
        }
    }
    // Failures over the full grid, summed over alpha, mu_a and eta, per theta_i x beta.
    let betas: Vec<f64> = {
        let mut b: Vec<f64> = grid.iter().map(|p| p.beta).collect();
        b.sort_by(f64::total_cmp);
        b.dedup();
        b
    };
    let panels: Vec<(String, Vec<f64>)> = Method::ALL
        .iter()
        .enumerate()
        .map(|(k, m)| {
            let mut values = vec![0.0; thetas.len() * betas.len()];
            for (p, row) in grid.iter().zip(health) {
                let (Some(y), Some(x)) =
                    (thetas.iter().position(|&t| t == p.theta), betas.iter().position(|&b| b == p.beta))
                else {
                    continue;
                };
                let h = row[k];
                values[y * betas.len() + x] += (h.non_finite + h.negative + h.inconsistent) as f64;
            }
            (m.name().to_string(), values)
        })
        .collect();
    let x_ticks: Vec<String> = betas.iter().map(|b| format!("{b}")).collect();
    CellMap {
        title: "NaN/Inf, negative and inconsistent values over the full grid (summed over alpha, mu_a, eta)",
        x_label: "roughness beta",
        y_label: "theta_i (rad)",
        x_ticks: &x_ticks,
        y_ticks: &y_ticks,
        panels: &panels,
        scale: CellScale::Log { hi: 1000.0, decades: 3.0 },
        format: &|v| format!("{v:.0}"),
    }
    .write(&dir.join("grid_failures.png"))
}

fn summary(args: &StabilitySettings, grid: &[GridPoint], health: &[Vec<Health>], rows: &[SliceRow]) -> String {
    let mut md = String::new();
    let _ = writeln!(md, "# Stability of every fiber model and sampler\n");
    let _ = writeln!(
        md,
        "`dualhair stability{}{}` ({} grid points x {} offsets h x 8 directions and 8 samples; slices with {} directions per estimate, {} simulated rays per point).\n",
        if args.quick { " --quick" } else { "" },
        format_args!(" --samples {} --rays {} --hits {} --seed {}", args.samples, args.rays, args.hits, args.seed),
        grid.len(),
        args.hits,
        args.samples,
        args.rays
    );
    let _ = writeln!(md, "## Full grid\n");
    let _ = writeln!(md, "| method | values | NaN/Inf | negative | sample != eval_pdf | no direction drawn |");
    let _ = writeln!(md, "|---|---|---|---|---|---|");
    for (k, m) in Method::ALL.iter().enumerate() {
        let total = health.iter().fold(Health::default(), |mut a, row| {
            let h = row[k];
            a.values += h.values;
            a.non_finite += h.non_finite;
            a.negative += h.negative;
            a.inconsistent += h.inconsistent;
            a.no_direction += h.no_direction;
            a
        });
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} | {} |",
            m.name(),
            total.values,
            total.non_finite,
            total.negative,
            total.inconsistent,
            total.no_direction
        );
    }
    let _ = writeln!(md, "\n## Slices: worst cells per method\n");
    let _ = writeln!(
        md,
        "| method | albedo range | max abs(pdf integral - 1) | largest significant abs(estimate / albedo - 1) (at theta_i) | max abs(z) vs uniform | fibersim distance range (noise floor) |"
    );
    let _ = writeln!(md, "|---|---|---|---|---|---|");
    for m in &Method::ALL {
        let mine: Vec<&SliceRow> = rows.iter().filter(|r| r.method == *m).collect();
        let range = |f: &dyn Fn(&SliceRow) -> f64| {
            let v: Vec<f64> = mine.iter().map(|r| f(r)).filter(|v| v.is_finite()).collect();
            (v.iter().copied().fold(f64::INFINITY, f64::min), v.iter().copied().fold(f64::NEG_INFINITY, f64::max))
        };
        let worst = |f: &dyn Fn(&SliceRow) -> f64| {
            mine.iter()
                .map(|r| (f(r).abs(), r.point.theta))
                .fold((0.0f64, 0.0), |a, b| if b.0 > a.0 || b.0.is_nan() { b } else { a })
        };
        let albedo = range(&|r| r.est.albedo.mean);
        let pdf = worst(&|r| r.est.pdf_integral.mean - 1.0);
        // Only differences beyond 4 standard errors count as bias; smaller ones are noise.
        let bias = worst(&|r| if r.importance_bias_z().abs() > 4.0 { r.importance_bias() } else { 0.0 });
        let z = worst(&|r| r.importance_vs_uniform());
        let dist = range(&|r| r.sim.map_or(f64::NAN, |s| s.0));
        let floor = range(&|r| r.sim.map_or(f64::NAN, |s| s.1));
        let _ = writeln!(
            md,
            "| {} | {:.3} .. {:.3} | {:.3} | {:.3} ({}) | {:.1} | {:.3} .. {:.3} ({:.3} .. {:.3}) |",
            m.name(),
            albedo.0,
            albedo.1,
            pdf.0,
            bias.0,
            bias.1,
            z.0,
            dist.0,
            dist.1,
            floor.0,
            floor.1
        );
    }
    md
}
