//! What the full, quick and tiny modes run.

use pivotsim_server::solver::Variant;

use super::ReportConfig;

/// Scenes, variants, durations and sweep points of one mode.
#[derive(Debug, Clone)]
pub struct Plan {
    /// `full`, `quick` or `tiny`.
    pub mode: &'static str,
    /// Built-in scenes of stage 1–3.
    pub scenes: Vec<&'static str>,
    /// Exact variants of stage 1 (`full` first: the others' speed-up is over it).
    pub variants: Vec<Variant>,
    /// Rounds of stage 1: each round runs every variant once, in turn, and each variant reports
    /// its median run (the host's speed drifts between runs; see `scenes.rs`).
    pub scene_rounds: usize,
    /// Simulated seconds of each scene run (`None`: the scene's own, 20 s).
    pub duration: Option<f64>,
    /// The `auto` run dumps its islands every this many steps.
    pub dump_every: usize,
    /// Islands per scene analysed in stage 2 (spread over the run).
    pub islands: usize,
    /// PGS sweeps of the trade.
    pub pgs_sweeps: Vec<usize>,
    /// Block-pivoting caps of the trade.
    pub bpp_caps: Vec<usize>,
    /// Repeats of each timed solve in the trade (the fastest counts).
    pub repeats: usize,
    /// Compliances of the winch sweep (joints and contacts alike).
    pub compliances: Vec<f64>,
    /// Mass ratios (load / lightest body) of the crane sweep.
    pub mass_ratios: Vec<f64>,
    /// Simulated seconds of each extremes run.
    pub extreme_duration: f64,
    /// Methods of the extremes sweeps.
    pub extreme_variants: Vec<Variant>,
    /// Matrix sizes of Fig. 4.
    pub fig4_sizes: Vec<usize>,
    /// Tight percentages of Fig. 4.
    pub fig4_fracs: Vec<f64>,
    /// Target µs of one timing sample of Fig. 4.
    pub fig4_target_us: f64,
    /// Mass ratios of the rapier comparison (`rapier.rs`).
    pub rapier_ratios: Vec<f64>,
    /// Simulated seconds of each run of the rapier comparison.
    #[cfg_attr(not(feature = "rapier"), allow(dead_code))]
    pub rapier_duration: f64,
}

impl Plan {
    /// The plan of a configuration.
    pub fn for_config(cfg: &ReportConfig) -> Self {
        if cfg.tiny {
            return Plan {
                mode: "tiny",
                scenes: vec!["forklift"],
                variants: vec![Variant::Full, Variant::Auto],
                scene_rounds: 1,
                duration: Some(0.25),
                dump_every: 5,
                islands: 2,
                pgs_sweeps: vec![1, 10],
                bpp_caps: vec![1, 35],
                repeats: 1,
                compliances: vec![1e-8],
                mass_ratios: vec![1e3],
                extreme_duration: 0.1,
                extreme_variants: vec![Variant::Auto, Variant::Pgs],
                fig4_sizes: vec![20],
                fig4_fracs: vec![10.0, 50.0],
                fig4_target_us: 20.0,
                rapier_ratios: vec![1e1, 1e9],
                rapier_duration: 0.25,
            };
        }
        let all_scenes = vec!["forklift", "winch", "forwarder", "crane", "offshore", "vehicle"];
        let variants = Variant::EXACT.to_vec();
        if cfg.quick {
            return Plan {
                mode: "quick",
                scenes: all_scenes,
                variants,
                scene_rounds: 1,
                duration: Some(4.0),
                dump_every: 40,
                islands: 4,
                pgs_sweeps: vec![1, 10, 100, 1000],
                bpp_caps: vec![1, 5, 35],
                repeats: 1,
                compliances: vec![1e-6, 1e-10, 1e-12],
                mass_ratios: vec![1e2, 1e5, 1e9],
                extreme_duration: 2.0,
                extreme_variants: vec![Variant::Auto, Variant::Pgs],
                fig4_sizes: vec![50, 200],
                fig4_fracs: vec![5.0, 20.0, 50.0],
                fig4_target_us: 300.0,
                rapier_ratios: vec![1e1, 1e5, 1e9],
                rapier_duration: 3.0,
            };
        }
        Plan {
            mode: "full",
            scenes: all_scenes,
            variants,
            scene_rounds: 5,
            duration: None,
            dump_every: 30,
            islands: 12,
            pgs_sweeps: vec![1, 2, 5, 10, 20, 50, 100, 200, 500, 1000],
            bpp_caps: vec![1, 2, 3, 5, 8, 13, 21, 35],
            repeats: 3,
            compliances: vec![1e-4, 1e-6, 1e-8, 1e-10, 1e-12],
            mass_ratios: vec![1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9],
            extreme_duration: 5.0,
            extreme_variants: vec![
                Variant::Auto,
                Variant::Full,
                Variant::Downdate,
                Variant::Skyline,
                Variant::SkylineRefactor,
                Variant::Incremental,
                Variant::Pgs,
            ],
            fig4_sizes: vec![50, 100, 200, 430, 700],
            fig4_fracs: vec![1.0, 5.0, 10.0, 20.0, 30.0, 50.0],
            fig4_target_us: 1_000.0,
            rapier_ratios: vec![1e1, 1e3, 1e5, 1e7, 1e9],
            rapier_duration: 5.0,
        }
    }

    /// Units of work for the progress bar: scene runs (with the paired one), island sets, extremes runs, Fig. 4 sizes,
    /// equal-time scenes, rapier runs.
    pub fn units(&self) -> u64 {
        // Per scene: a run per variant and round, `auto` cold, and `full` with the paired shadows.
        let runs = self.scenes.len() * (self.variants.len() * self.scene_rounds + 2);
        let islands = self.scenes.len();
        let extremes = self.extreme_variants.len() * (self.compliances.len() + self.mass_ratios.len());
        let rapier = if super::rapier::BUILT { 3 * 2 * self.rapier_ratios.len() } else { 0 };
        let faults = super::faults::runs(self.mode).len();
        (runs + islands + extremes + self.fig4_sizes.len() + self.scenes.len() + rapier + faults) as u64
    }
}
