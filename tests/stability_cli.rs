//! End-to-end check of `dualhair stability` on its quick grid: every output is written, every
//! method is measured, the known failure (Box-Muller's density at grazing light, Ou et al. 2012
//! Appendix B) shows where the exact sampler of the same model does not, and bad input fails.

use crate::common::dualhair;

#[test]
fn quick_run_writes_every_output_and_shows_box_mullers_failure() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("stability");
    let o = out.to_str().unwrap();
    let run = dualhair(&["stability", "--quick", "--samples", "3000", "--rays", "4000", "--hits", "2", "-q", "-o", o]);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    for file in
        ["grid.csv", "slices.csv", "summary.md", "grid_failures.png", "beta_albedo.png", "mu_a_pdf_integral.png"]
    {
        assert!(out.join(file).is_file(), "{file} missing");
    }
    assert!(out.join("beta_fibersim_distance.png").is_file());
    assert!(out.join("lobes/1.png").is_file());
    let summary = std::fs::read_to_string(out.join("summary.md")).unwrap();
    for method in ["chiang-dEon2013", "marschner-thesis", "sadeghi-box_muller", "deon2014-iterative"] {
        assert!(summary.contains(method), "{method} not in the summary");
    }

    // Ou et al. 2012 Appendix B: Box-Muller's density ignores the mass it clips, which matters once the
    // lobes are wide and the light grazing; at normal incidence it is right. The Cauchy sampler
    // of the same model is exact everywhere.
    let csv = std::fs::read_to_string(out.join("slices.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    // Quick grid: 4 inclinations x (4 roughnesses + 5 absorptions + 2 tilts), every method.
    assert_eq!(rows.len(), 4 * 11 * 7);
    let at = |m: &str, theta: &str| -> (f64, f64) {
        let r = rows
            .iter()
            .find(|r| {
                r[col("slice")] == "beta"
                    && r[col("method")] == m
                    && r[col("theta")] == theta
                    && r[col("beta")] == "0.3"
            })
            .unwrap();
        (r[col("pdf_integral")].parse().unwrap(), r[col("importance_bias_z")].parse().unwrap())
    };
    for (m, theta) in [("sadeghi-cauchy", "0"), ("sadeghi-cauchy", "1.5"), ("sadeghi-box_muller", "0")] {
        let (pdf, z) = at(m, theta);
        assert!((pdf - 1.0).abs() < 0.05 && z.abs() < 4.0, "{m} at theta {theta}: pdf integral {pdf}, bias z {z}");
    }
    let (pdf, z) = at("sadeghi-box_muller", "1.5");
    println!("Box-Muller at theta 1.5, beta 0.3: pdf integral {pdf}, bias {z} standard errors");
    assert!(pdf < 0.8 && z > 10.0, "pdf integral {pdf}, bias z {z}");
}

#[test]
fn bad_input_is_an_error_naming_the_flag() {
    let dir = tempfile::tempdir().unwrap();
    let o = dir.path().join("s");
    for (flag, value) in [("--samples", "1"), ("--hits", "0"), ("--rays", "2000000000")] {
        let run = dualhair(&["stability", flag, value, "-q", "-o", o.to_str().unwrap()]);
        assert!(!run.status.success());
        let err = String::from_utf8_lossy(&run.stderr);
        assert!(err.contains(flag), "{flag}: {err}");
        assert!(!o.exists(), "{flag}: nothing must be written");
    }
}
