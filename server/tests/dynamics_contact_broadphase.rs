//! The sweep-and-prune broad phase (issue 5) finds exactly the pairs of the all-pairs AABB test:
//! on seeded random scenes moving coherently for many steps (the persistent order re-sorted by
//! insertion sort), with jumps, touching boxes, equal bounds and unbounded volumes, and on
//! proptest-generated integer boxes (many ties). `cargo test --release --test
//! dynamics_contact_broadphase -- --ignored --nocapture` times it against all pairs on 1000 boxes.

use std::time::Instant;

use nalgebra::Vector3;
use pivotsim_server::dynamics::{Bounds, SweepAndPrune};
use proptest::prelude::*;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// All pairs `(i, j)`, `i < j`, whose closed boxes overlap, or of which exactly one is unbounded.
fn brute_force(bounds: &[Bounds]) -> Vec<(u32, u32)> {
    let mut out = Vec::new();
    for i in 0..bounds.len() {
        for j in i + 1..bounds.len() {
            let hit = match (&bounds[i], &bounds[j]) {
                (Some((a0, a1)), Some((b0, b1))) => (0..3).all(|k| a0[k] <= b1[k] && b0[k] <= a1[k]),
                (None, None) => false,
                _ => true,
            };
            if hit {
                out.push((i as u32, j as u32));
            }
        }
    }
    out
}

/// `n` random boxes in a `size`³ region (half extents up to `max_half`), a fraction unbounded.
fn random_scene(rng: &mut ChaCha8Rng, n: usize, size: f64, max_half: f64, unbounded: f64) -> Vec<Bounds> {
    (0..n)
        .map(|_| {
            if rng.random_range(0.0..1.0) < unbounded {
                return None;
            }
            let c = Vector3::from_fn(|_, _| rng.random_range(0.0..size));
            let e = Vector3::from_fn(|_, _| rng.random_range(0.0..max_half));
            Some((c - e, c + e))
        })
        .collect()
}

#[test]
fn sweep_and_prune_equals_all_pairs_on_random_moving_scenes() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let mut checked = 0;
    let mut total_pairs = 0;
    for (n, size, max_half, unbounded) in [
        (0, 1.0, 0.1, 0.0),
        (1, 1.0, 0.1, 0.0),
        (2, 1.0, 0.6, 0.5),
        (30, 2.0, 0.5, 0.1),
        (300, 10.0, 0.5, 0.01),
    ] {
        let mut sap = SweepAndPrune::new();
        let mut bounds = random_scene(&mut rng, n, size, max_half, unbounded);
        for step in 0..60 {
            let want = brute_force(&bounds);
            assert_eq!(sap.update(&bounds), want.as_slice(), "n = {n}, step {step}");
            assert_eq!(sap.pairs(), want.as_slice());
            total_pairs += want.len();
            checked += 1;
            // Coherent motion (1 % of the size per step), now and then a jump, a box turned
            // unbounded or back, or an exact copy of another box (equal bounds, ties on x).
            for k in 0..n {
                let r: f64 = rng.random_range(0.0..1.0);
                if r < 0.01 {
                    bounds[k] = random_scene(&mut rng, 1, size, max_half, 0.3)[0];
                } else if r < 0.02 {
                    bounds[k] = bounds[rng.random_range(0..n)];
                } else if let Some((lo, hi)) = &mut bounds[k] {
                    let d = Vector3::from_fn(|_, _| rng.random_range(-0.01..0.01) * size);
                    *lo += d;
                    *hi += d;
                }
            }
        }
    }
    eprintln!("sweep and prune = all pairs on {checked} random scene states ({total_pairs} pairs in all)");
}

#[test]
fn touching_boxes_and_a_degenerate_axis() {
    // Boxes touching face to face (closed intervals), and all of them on one x interval (the sweep
    // degenerates to all pairs on x and must still test y and z).
    let b = |x: f64, y: f64, z: f64| Some((Vector3::new(x, y, z), Vector3::new(x + 1.0, y + 1.0, z + 1.0)));
    let row: Vec<Bounds> = (0..10).map(|k| b(k as f64, 0.0, 0.0)).collect();
    let column: Vec<Bounds> = (0..10).map(|k| b(0.0, k as f64 * 1.5, (k % 2) as f64)).collect();
    let mut sap = SweepAndPrune::new();
    for scene in [&row, &column] {
        assert_eq!(sap.update(scene), brute_force(scene).as_slice());
    }
    assert_eq!(sap.update(&row).len(), 9, "neighbours touch");
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    /// Integer boxes on a small grid: many equal bounds and touching faces; the broad phase is fed
    /// two scenes in a row (the second re-sorts the first's order).
    #[test]
    fn sweep_and_prune_equals_all_pairs_on_integer_boxes(
        first in prop::collection::vec(prop::option::weighted(0.9, ([0i32..6, 0..6, 0..6], [0i32..3, 0..3, 0..3])), 0..40),
        shift in prop::collection::vec([-2i32..3, -2..3, -2..3], 40),
    ) {
        let to_bounds = |(lo, len): ([i32; 3], [i32; 3])| {
            let lo = Vector3::new(lo[0] as f64, lo[1] as f64, lo[2] as f64);
            (lo, lo + Vector3::new(len[0] as f64, len[1] as f64, len[2] as f64))
        };
        let a: Vec<Bounds> = first.iter().map(|b| b.map(to_bounds)).collect();
        let b: Vec<Bounds> = a
            .iter()
            .zip(&shift)
            .map(|(b, s)| b.map(|(lo, hi)| {
                let d = Vector3::new(s[0] as f64, s[1] as f64, s[2] as f64);
                (lo + d, hi + d)
            }))
            .collect();
        let mut sap = SweepAndPrune::new();
        for scene in [&a, &b] {
            let want = brute_force(scene);
            prop_assert_eq!(sap.update(scene), want.as_slice());
        }
    }
}

/// Mean time per call of `f` over `n` calls (µs).
fn time_us(n: usize, mut f: impl FnMut()) -> f64 {
    let t = Instant::now();
    for _ in 0..n {
        f();
    }
    t.elapsed().as_secs_f64() * 1e6 / n as f64
}

#[test]
#[ignore = "timing; run with --ignored --nocapture in release"]
fn bench_sweep_and_prune_vs_all_pairs_1000_boxes() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    // 1000 boxes of half extents up to 0.3 m: a 30 m × 30 m yard 2 m high, and a 10 m × 10 m pile.
    for (what, size_xy, size_z) in [("30 m yard", 30.0, 2.0), ("10 m pile", 10.0, 2.0)] {
        let mut bounds: Vec<Bounds> = (0..1000)
            .map(|_| {
                let c = Vector3::new(
                    rng.random_range(0.0..size_xy),
                    rng.random_range(0.0..size_xy),
                    rng.random_range(0.0..size_z),
                );
                let e = Vector3::from_fn(|_, _| rng.random_range(0.05..0.3));
                Some((c - e, c + e))
            })
            .collect();
        let moves: Vec<Vector3<f64>> =
            (0..1000).map(|_| Vector3::from_fn(|_, _| rng.random_range(-1e-3..1e-3))).collect();
        let mut sap = SweepAndPrune::new();
        let pairs = sap.update(&bounds).len();
        let mut sign = 1.0;
        let t_sap = time_us(200, || {
            // One step of coherent motion (±1 mm), then the update.
            sign = -sign;
            for (b, d) in bounds.iter_mut().zip(&moves) {
                if let Some((lo, hi)) = b {
                    *lo += sign * d;
                    *hi += sign * d;
                }
            }
            std::hint::black_box(sap.update(&bounds));
        });
        let mut fresh_sap = 0.0;
        let t_cold = time_us(50, || {
            let mut cold = SweepAndPrune::new();
            fresh_sap += cold.update(&bounds).len() as f64;
        });
        let t_all = time_us(20, || {
            std::hint::black_box(brute_force(&bounds));
        });
        assert_eq!(sap.update(&bounds), brute_force(&bounds).as_slice());
        eprintln!(
            "1000 boxes, {what}: {pairs} pairs; sweep and prune {t_sap:.1} µs per step (coherent motion), \
             {t_cold:.1} µs from scratch; all pairs {t_all:.1} µs ({:.0}× slower)",
            t_all / t_sap
        );
    }
}
