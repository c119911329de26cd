//! How much `bench-solver` measures: sizes, repeats and time budgets of the tiny, quick and full
//! modes, and the paper's step caps.

use super::BenchConfig;

/// Step cap of the paper (Table 1).
pub const SHORT_STEPS: usize = 35;
/// Generous step cap: does the pivoting converge at all?
pub const LONG_STEPS: usize = 1000;

/// Sizes, repeats and budgets of one mode.
#[derive(Debug, Clone)]
pub struct Plan {
    pub mode: &'static str,
    /// Target duration of one timing sample of a kernel (µs); the kernel is looped to fill it.
    pub kernel_target_us: f64,
    pub kernel_repeats: usize,
    pub kernel_m: usize,
    pub kernel_t_max: usize,
    /// Random tight sets averaged per tight count in the envelope sweep.
    pub kernel_sets: usize,
    pub dense_repeats: usize,
    pub dense_fracs: Vec<f64>,
    pub fig4_m: Vec<usize>,
    pub fig4_fracs: Vec<f64>,
    pub fig4_target_us: f64,
    pub fig4_repeats: usize,
    /// Generated problems: (target size, seed, mass ratio).
    pub generated: Vec<(usize, u64, f64)>,
    /// Time budget for the repeats of one 35-step measurement (µs).
    pub solve_budget_us: f64,
    pub solve_max_repeats: usize,
    /// Largest predicted duration of a single 1000-step or deletion-error run (µs).
    pub long_budget_us: f64,
    /// Generated size whose problems the summary reports on.
    pub focus_m: usize,
    /// Busy work before the first timing (µs).
    pub warm_up_us: f64,
}

impl Plan {
    pub fn for_config(cfg: &BenchConfig) -> Self {
        if cfg.tiny {
            return Plan {
                mode: "tiny",
                kernel_target_us: 50.0,
                kernel_repeats: 3,
                kernel_m: 60,
                kernel_t_max: 8,
                kernel_sets: 1,
                dense_repeats: 1,
                dense_fracs: vec![5.0, 20.0],
                fig4_m: vec![20, 40],
                fig4_fracs: vec![5.0, 20.0, 50.0],
                fig4_target_us: 50.0,
                fig4_repeats: 1,
                generated: vec![(40, 1, 100.0)],
                solve_budget_us: 5_000.0,
                solve_max_repeats: 2,
                long_budget_us: 500_000.0,
                focus_m: 40,
                warm_up_us: 0.0,
            };
        }
        let fig4_fracs = vec![1.0, 5.0, 10.0, 15.0, 20.0, 30.0, 50.0];
        if cfg.quick {
            Plan {
                mode: "quick",
                kernel_target_us: 300.0,
                kernel_repeats: 5,
                kernel_m: 430,
                kernel_t_max: 40,
                kernel_sets: 3,
                dense_repeats: 3,
                dense_fracs: vec![1.0, 2.0, 3.0, 5.0, 7.0, 10.0, 15.0, 20.0, 30.0],
                fig4_m: vec![50, 100, 200],
                fig4_fracs,
                fig4_target_us: 2_000.0,
                fig4_repeats: 3,
                generated: vec![(100, 1, 6_300.0), (430, 5, 6_300.0), (430, 6, 400.0)],
                solve_budget_us: 100_000.0,
                solve_max_repeats: 9,
                long_budget_us: 1_000_000.0,
                focus_m: 430,
                warm_up_us: 300_000.0,
            }
        } else {
            Plan {
                mode: "full",
                kernel_target_us: 1_000.0,
                kernel_repeats: 9,
                kernel_m: 430,
                kernel_t_max: 64,
                kernel_sets: 5,
                dense_repeats: 5,
                dense_fracs: vec![
                    1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0, 12.0, 15.0, 20.0, 25.0, 30.0, 40.0,
                ],
                fig4_m: vec![50, 100, 200, 400, 700, 1000],
                fig4_fracs,
                fig4_target_us: 5_000.0,
                fig4_repeats: 5,
                generated: vec![
                    (100, 1, 6_300.0),
                    (100, 2, 400.0),
                    (200, 3, 6_300.0),
                    (200, 4, 20_000.0),
                    (430, 5, 6_300.0),
                    (430, 6, 400.0),
                    (430, 7, 20_000.0),
                    (1000, 8, 6_300.0),
                ],
                solve_budget_us: 600_000.0,
                solve_max_repeats: 21,
                long_budget_us: 20_000_000.0,
                focus_m: 430,
                warm_up_us: 1_000_000.0,
            }
        }
    }
}
