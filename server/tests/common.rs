//! Shared helpers of the solver integration tests: seeded random boxed problems.

#![allow(dead_code)]

use pivotsim_server::solver::{Mlcp, SymCsr};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A random SPD boxed problem: `A = B Bᵀ/n + shift·I` with a sparse `B`, bounds mixing bilateral
/// rows, `[0, ∞)` and finite boxes; with `friction`, every third row after the first is a normal row
/// followed by two friction rows (`μ ∈ [0.3, 1]`).
pub fn random_problem(n: usize, seed: u64, friction: bool, density: f64, shift: f64) -> Mlcp {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut b = vec![0.0; n * n];
    for i in 0..n {
        b[i * n + i] = rng.random_range(0.5..1.5);
        for j in 0..n {
            if j != i && rng.random_range(0.0..1.0) < density {
                b[i * n + j] = rng.random_range(-1.0..1.0);
            }
        }
    }
    let mut a = vec![0.0; n * n];
    for i in 0..n {
        for j in 0..=i {
            let mut s = 0.0;
            for k in 0..n {
                s += b[i * n + k] * b[j * n + k];
            }
            a[i * n + j] = s;
            a[j * n + i] = s;
        }
        a[i * n + i] += shift;
    }
    let rhs: Vec<f64> = (0..n).map(|_| rng.random_range(-2.0..2.0)).collect();
    let mut lo = vec![0.0; n];
    let mut hi = vec![0.0; n];
    let mut findex = vec![None; n];
    let mut i = 0;
    while i < n {
        if friction && i + 2 < n && rng.random_range(0.0..1.0) < 0.5 {
            let mu = rng.random_range(0.3..1.0);
            lo[i] = 0.0;
            hi[i] = f64::INFINITY;
            for k in 1..3 {
                lo[i + k] = -mu;
                hi[i + k] = mu;
                findex[i + k] = Some(i);
            }
            i += 3;
            continue;
        }
        match rng.random_range(0..4) {
            0 => {
                lo[i] = f64::NEG_INFINITY;
                hi[i] = f64::INFINITY;
            }
            1 => {
                lo[i] = 0.0;
                hi[i] = f64::INFINITY;
            }
            2 => {
                lo[i] = -rng.random_range(0.1..1.0);
                hi[i] = rng.random_range(0.1..1.0);
            }
            _ => {
                lo[i] = f64::NEG_INFINITY;
                hi[i] = rng.random_range(-0.5..0.5);
            }
        }
        i += 1;
    }
    Mlcp::new(SymCsr::from_dense_row_major(n, &a).unwrap(), rhs, lo, hi, findex).unwrap()
}

/// A banded SPD problem of size `n` (bandwidth `bw`), rows shuffled, so that orderings matter.
pub fn banded_problem(n: usize, bw: usize, seed: u64, tight_bias: f64) -> Mlcp {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut perm: Vec<usize> = (0..n).collect();
    for i in (1..n).rev() {
        let j = rng.random_range(0..=i);
        perm.swap(i, j);
    }
    let mut trip = Vec::new();
    let mut diag = vec![0.5; n];
    for i in 0..n {
        for j in i.saturating_sub(bw)..i {
            if rng.random_range(0.0..1.0) < 0.6 {
                let v: f64 = rng.random_range(-1.0..1.0);
                trip.push((perm[i], perm[j], v));
                trip.push((perm[j], perm[i], v));
                diag[i] += v.abs();
                diag[j] += v.abs();
            }
        }
    }
    for i in 0..n {
        trip.push((perm[i], perm[i], diag[i]));
    }
    let a = SymCsr::from_triplets(n, &trip).unwrap();
    let rhs: Vec<f64> = (0..n).map(|_| rng.random_range(-1.0..1.0) - tight_bias).collect();
    let lo = vec![0.0; n];
    let hi: Vec<f64> =
        (0..n).map(|_| if rng.random_range(0.0..1.0) < 0.3 { 0.5 } else { f64::INFINITY }).collect();
    Mlcp::new(a, rhs, lo, hi, vec![None; n]).unwrap()
}
