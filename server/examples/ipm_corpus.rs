//! Probe: pivot steps per corpus file with the interior point switch at several points.
use pivotsim_server::solver::io::read_mlcp_file;
use pivotsim_server::solver::{Mlcp, SolveStatus, Solver, SolverOptions, Variant};

fn main() {
    let dir = std::env::args().nth(1).unwrap_or("server/tests/data/corpus".into());
    let afters: Vec<usize> = std::env::args()
        .nth(2)
        .unwrap_or("999999,0,5,10,15".into())
        .split(',')
        .map(|s| s.parse().unwrap())
        .collect();
    let cap: usize = std::env::var("CAP").ok().and_then(|v| v.parse().ok()).unwrap_or(300);
    let mut files: Vec<_> = std::fs::read_dir(&dir).unwrap().filter_map(|e| e.ok()).map(|e| e.path()).collect();
    files.retain(|p| p.extension().is_some_and(|e| e == "txt"));
    files.sort();
    for cold in [true, false] {
        println!("== {} == ipm_after {:?}", if cold { "cold" } else { "warm" }, afters);
        let mut within = vec![0usize; afters.len()];
        let mut within100 = vec![0usize; afters.len()];
        let mut time = vec![0.0f64; afters.len()];
        for f in &files {
            let p0 = read_mlcp_file(f).unwrap();
            let p = if cold { p0.without_warm_start() } else { p0.clone() };
            let mut line = format!("{:46}", f.file_name().unwrap().to_string_lossy());
            for (k, &a) in afters.iter().enumerate() {
                let (steps, ok, ipm, us, rr) = run(&p, a, cap);
                if ok && steps <= 35 {
                    within[k] += 1;
                }
                if ok && steps <= 100 {
                    within100[k] += 1;
                }
                time[k] += us;
                line += &format!(" {:>4}{}{}", steps, if ok { " " } else { "!" }, if ipm > 0 { format!("({ipm:>2})") } else { "    ".into() });
                let _ = rr;
            }
            println!("{line}");
        }
        println!("within 35: {within:?}  within 100: {within100:?}  total ms {:?}", time.iter().map(|t| (t / 1e3 * 10.0).round() / 10.0).collect::<Vec<_>>());
    }
}

fn run(p: &Mlcp, after: usize, cap: usize) -> (usize, bool, usize, f64, f64) {
    let opts = SolverOptions { variant: Variant::Auto, max_steps: cap, ipm_after: after, ipm_cold_after: std::env::var("IPM_COLD").ok().and_then(|v| v.parse().ok()).unwrap_or(3), ..SolverOptions::default() };
    let mut s = Solver::new(opts);
    let mut lam = vec![0.0; p.n()];
    let st = s.solve(p, &mut lam);
    (st.pivot_steps, st.status == SolveStatus::Converged, st.ipm_iterations, st.total_us, st.residual_rel)
}
