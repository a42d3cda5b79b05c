use precompute::conventions::direction;
use precompute::fiber::*;
fn main() {
    for bm in [0.1, 0.3, 0.9] {
        let m = Chiang::new(&FiberParams { beta_m: bm, ..Default::default() }).unwrap();
        let wo = direction(0.4, 0.3);
        let t = std::time::Instant::now();
        let mut s = 0.0;
        for i in 0..2_000_000 {
            let x = i as f64 / 2e6;
            s += m.eval(wo, direction(x * 3.0 - 1.5, x * 1000.0), x * 2.0 - 1.0).0[0];
        }
        println!("beta_m {bm}: {:.0} ns/eval ({s})", t.elapsed().as_nanos() as f64 / 2e6);
    }
}
