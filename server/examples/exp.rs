// Local experiment harness (not committed): solve files with options given as key=value.
use pivotsim_server::solver::{Solver, SolverOptions, io};
fn main() {
    let mut opts = SolverOptions { max_steps: 100, ..Default::default() };
    let mut files = vec![];
    let mut cold = false;
    let mut reps = 1usize;
    for a in std::env::args().skip(1) {
        if let Some((k, v)) = a.split_once('=') {
            match k {
                "ipm_after" => opts.ipm_after = v.parse().unwrap(),
                "ipm_cold_after" => opts.ipm_cold_after = v.parse().unwrap(),
                "murty_after" => opts.murty_after = v.parse().unwrap(),
                "projected_arc" => opts.projected_arc = v.parse().unwrap(),
                "wd" => opts.auto_weights.0 = v.parse().unwrap(),
                "wf" => opts.auto_weights.2 = v.parse().unwrap(),
                "newton_first" => opts.newton_first = v.parse().unwrap(),
                "safeguard_after_update" => opts.safeguard_after_update = v.parse().unwrap(),
                "max_steps" => opts.max_steps = v.parse().unwrap(),
                "variant" => opts.variant = v.parse().unwrap(),
                "cold" => cold = v.parse().unwrap(),
                "reps" => reps = v.parse().unwrap(),
                _ => panic!("unknown {k}"),
            }
        } else {
            files.push(a);
        }
    }
    let mut tot = 0.0;
    let mut conv35 = 0;
    for f in &files {
        let mut p = io::read_mlcp_file(std::path::Path::new(f)).unwrap();
        if cold {
            p = p.without_warm_start();
        }
        let mut solver = Solver::new(opts.clone());
        let mut lambda = vec![0.0; p.n()];
        let mut best = f64::MAX;
        let mut st = None;
        for _ in 0..reps {
            lambda.iter_mut().for_each(|x| *x = 0.0);
            let t = std::time::Instant::now();
            let s = solver.solve(&p, &mut lambda).clone();
            best = best.min(t.elapsed().as_secs_f64() * 1e6);
            st = Some(s);
        }
        let st = st.unwrap();
        tot += best;
        if st.pivot_steps <= 35 && format!("{:?}", st.status) == "Converged" {
            conv35 += 1;
        }
        println!(
            "order={:.1} factor={:.1} downdate={:.1} solve={:.1} total={:.1} choices={:?} l0={}",
            st.ordering_us,
            st.factor_us,
            st.downdate_us,
            st.solve_us,
            st.total_us,
            st.auto_choices,
            st.l0_factored
        );
        println!(
            "{:50} {:?} steps={} tight={} res={:.1e} ipm={}/{} pn={} ps={} fu={} t={:.0}us",
            std::path::Path::new(f).file_name().unwrap().to_string_lossy(),
            st.status,
            st.pivot_steps,
            st.tight,
            st.residual_rel,
            st.ipm_runs,
            st.ipm_iterations,
            st.projected_newton_steps,
            st.projected_steps,
            st.friction_updates,
            best
        );
    }
    println!("total {:.0} us, converged within 35: {}/{}", tot, conv35, files.len());
}
