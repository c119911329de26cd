//! Every problem in `tests/data/siconos` (Siconos test problems written by others) and
//! `tests/data/scene-shaped` (paper-like islands) solved by every exact variant, judged by the
//! natural-map residual against the true (final-normal-impulse) friction bounds.
//!
//! Every file must converge within 1000 pivot steps to a relative residual of 1e-9 (1e-6 where
//! the factorization had to regularize a semidefinite `A`), and the reported residual must be the
//! one of the returned `λ`.

use std::path::PathBuf;

use pivotsim_server::solver::{SolveStatus, Solver, SolverOptions, Variant, io};

fn files() -> Vec<PathBuf> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    let mut out = Vec::new();
    for dir in ["siconos", "scene-shaped"] {
        let Ok(rd) = std::fs::read_dir(root.join(dir)) else { continue };
        for e in rd.flatten() {
            let p = e.path();
            if p.extension().is_some_and(|x| x == "txt") {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

#[test]
fn every_data_problem_with_every_exact_variant() {
    let files = files();
    assert!(files.len() >= 20, "test problems not found in server/tests/data ({} files)", files.len());
    let mut report = Vec::new();
    let mut unexpected = Vec::new();
    for f in &files {
        let name = f.file_name().unwrap().to_string_lossy().to_string();
        let p = io::read_mlcp_file(f).unwrap_or_else(|e| panic!("{name}: {e}"));
        for v in Variant::EXACT {
            let mut s = Solver::new(SolverOptions { variant: v, max_steps: 1000, ..Default::default() });
            let mut lam = vec![0.0; p.n()];
            let st = s.solve(&p, &mut lam).clone();
            assert!(lam.iter().all(|x| x.is_finite()), "{name} {v}: non-finite λ");
            let mut w = vec![0.0; p.n()];
            let (r, rr) = p.natural_residual(&lam, &mut w);
            assert!(
                (r - st.residual).abs() <= 1e-9 * (1.0 + r),
                "{name} {v}: reported {} vs {r}",
                st.residual
            );
            // 1e-9, or 1e-6 where A had to be regularized. The residual is relative to ‖λ‖∞ while
            // its free rows carry w-units: once 100 ulps of max|A| exceed 1e-9 (relay1: max|A| ≈ 1e7),
            // that is the floor double precision allows.
            let a_max = p.a().values().iter().fold(0.0f64, |m, x| m.max(x.abs()));
            let tol = if st.regularized > 0 { 1e-6 } else { 1e-9f64.max(100.0 * f64::EPSILON * a_max) };
            let ok = matches!(st.status, SolveStatus::Converged | SolveStatus::Inexact) && rr <= tol;
            report.push(format!(
                "{name:34} {v:17} {:10} steps {:4} residual_rel {rr:.2e}",
                st.status.name(),
                st.pivot_steps
            ));
            if !ok {
                unexpected.push(format!("{name} {v}: {} residual_rel {rr:e}", st.status.name()));
            }
        }
    }
    println!("{}", report.join("\n"));
    assert!(unexpected.is_empty(), "did not converge:\n{}", unexpected.join("\n"));
}

#[test]
fn pgs_is_reported_not_failed() {
    for f in files() {
        let p = io::read_mlcp_file(&f).unwrap();
        let mut s = Solver::new(SolverOptions { variant: Variant::Pgs, ..Default::default() });
        let mut lam = vec![0.0; p.n()];
        let st = s.solve(&p, &mut lam);
        assert!(lam.iter().all(|x| x.is_finite()));
        println!(
            "{:34} pgs {:10} sweeps {:4} residual_rel {:.2e}",
            f.file_name().unwrap().to_string_lossy(),
            st.status.name(),
            st.iterations,
            st.residual_rel
        );
    }
}
