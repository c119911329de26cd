//! The paper's other idea for warm starts (§5): order the rows that were tight at the previous step
//! last, so that deleting them from `L₀` touches only the trailing part of the factor.
//!
//! On each analysed island that carries a warm-start index set with tight rows: the island solved
//! with `skyline` and `auto` as the solver orders it (reverse Cuthill–McKee), and the same island
//! permuted beforehand to reverse Cuthill–McKee with the warm start's tight rows moved to the end
//! (stable: each group keeps its RCM order), solved in that order (`natural`). Measured per solve:
//! the envelope of `L` (entries), pivot steps and wall time (fastest of the plan's repeats); the
//! answers must agree (both exact), and the relative residual of the permuted solve is recorded.

use std::time::Instant;

use pivotsim_server::solver::ordering::OrderingWorkspace;
use pivotsim_server::solver::{
    IndexState, Mlcp, OrderingKind, SolveStatus, Solver, SolverOptions, SymCsr, Variant,
};
use serde::Serialize;

use super::spread::Spread;

/// One scene, one variant.
#[derive(Debug, Clone, Serialize)]
pub struct TightLast {
    /// Scene name.
    pub scene: String,
    /// `skyline` or `auto`.
    pub variant: String,
    /// Islands with a warm-start index set holding tight rows.
    pub islands: usize,
    /// Envelope entries, RCM / tight last (medians).
    pub envelope_rcm: f64,
    /// Envelope entries with the tight rows last.
    pub envelope_tight_last: f64,
    /// Solve time ratio tight last / RCM per island.
    pub time_ratio: Option<Spread>,
    /// Median solve time, RCM (µs).
    pub time_rcm_us: f64,
    /// Median solve time, tight last (µs).
    pub time_tight_last_us: f64,
    /// Islands where both converged.
    pub both_converged: usize,
}

/// Measures every scene's analysed islands.
pub fn run(scene: &str, problems: &[Mlcp], repeats: usize) -> Vec<TightLast> {
    let warm: Vec<(&Mlcp, Mlcp)> = problems
        .iter()
        .filter(|p| p.index0().is_some_and(|s| s.iter().any(|x| x.is_tight())))
        .filter_map(|p| tight_last(p).map(|q| (p, q)))
        .collect();
    [Variant::Skyline, Variant::Auto]
        .into_iter()
        .map(|v| {
            let mut rcm = Solver::new(SolverOptions { variant: v, ..Default::default() });
            let mut last = Solver::new(SolverOptions {
                variant: v,
                ordering: OrderingKind::Natural,
                ..Default::default()
            });
            let (mut env_a, mut env_b, mut t_a, mut t_b, mut ratio) =
                (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
            let mut both = 0;
            for (p, q) in &warm {
                let (ea, ta, ca) = timed(&mut rcm, p, repeats);
                let (eb, tb, cb) = timed(&mut last, q, repeats);
                env_a.push(ea as f64);
                env_b.push(eb as f64);
                t_a.push(ta);
                t_b.push(tb);
                if ta > 0.0 {
                    ratio.push(tb / ta);
                }
                both += (ca && cb) as usize;
            }
            let med = |x: Vec<f64>| Spread::of(x).map_or(f64::NAN, |s| s.median);
            TightLast {
                scene: scene.to_string(),
                variant: v.name().to_string(),
                islands: warm.len(),
                envelope_rcm: med(env_a),
                envelope_tight_last: med(env_b),
                time_ratio: Spread::of(ratio),
                time_rcm_us: med(t_a),
                time_tight_last_us: med(t_b),
                both_converged: both,
            }
        })
        .collect()
}

/// (envelope entries, fastest wall time in µs, converged).
fn timed(s: &mut Solver, p: &Mlcp, repeats: usize) -> (usize, f64, bool) {
    let mut lambda = vec![0.0; p.n()];
    let mut best = f64::INFINITY;
    let (mut env, mut ok) = (0, false);
    for _ in 0..repeats.max(1) {
        let t = Instant::now();
        let st = s.solve(p, &mut lambda);
        best = best.min(t.elapsed().as_secs_f64() * 1e6);
        env = st.envelope_after;
        ok = st.status == SolveStatus::Converged;
    }
    (env, best, ok)
}

/// `p` permuted to reverse Cuthill–McKee with its warm start's tight rows moved last.
fn tight_last(p: &Mlcp) -> Option<Mlcp> {
    let n = p.n();
    let index0 = p.index0()?;
    let (mut rcm, mut rcm_inv) = (Vec::new(), Vec::new());
    OrderingWorkspace::new().order(p.a(), OrderingKind::ReverseCuthillMcKee, &mut rcm, &mut rcm_inv);
    // perm[new] = old.
    let perm: Vec<usize> = rcm
        .iter()
        .copied()
        .filter(|&i| !index0[i].is_tight())
        .chain(rcm.iter().copied().filter(|&i| index0[i].is_tight()))
        .collect();
    let mut inv = vec![0; n];
    for (new, &old) in perm.iter().enumerate() {
        inv[old] = new;
    }
    let mut a = SymCsr::default();
    a.permuted_from(p.a(), &perm, &inv);
    let pick = |x: &[f64]| perm.iter().map(|&o| x[o]).collect::<Vec<f64>>();
    let findex = perm.iter().map(|&o| p.findex()[o].map(|j| inv[j])).collect();
    let index: Vec<IndexState> = perm.iter().map(|&o| index0[o]).collect();
    Mlcp::new(a, pick(p.b()), pick(p.lo()), pick(p.hi()), findex)
        .ok()?
        .with_warm_start(p.lambda0().map(pick), Some(index))
        .ok()
}
