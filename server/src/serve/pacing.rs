//! Real-time pacing of the loop: step `k` is due at `t₀ + k h / rtf` ([`step_period`]); a step
//! that ends after its deadline counts an overrun, and the loop never runs more than
//! [`MAX_CATCH_UP`] steps behind; and the periodic status line (`StatusWindow`).

use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use tracing::info;

use super::config::{MAX_STEP_PERIOD, ServeError};
use super::engine::Engine;
use super::transport::Transport;

/// Steps the loop may fall behind before it drops the backlog.
pub const MAX_CATCH_UP: u32 = 4;

/// Longest single sleep of the loop: Ctrl-C is seen within this even at a slow pace.
pub(crate) const MAX_SLEEP: Duration = Duration::from_millis(100);

/// Waits until step `next` (advanced by one period at real-time factor `rtf`) is due; when it is
/// already late, counts an overrun if a step ran (returns `true`) and drops a backlog of more than
/// [`MAX_CATCH_UP`] periods.
pub(crate) fn pace(
    next: &mut Instant,
    rtf: f64,
    stepped: bool,
    engine: &mut Engine,
    shutdown: &AtomicBool,
) -> bool {
    // A scene loaded later may have another h: its period is held to the same bound.
    let period = step_period(engine.scene().world.settings().timestep, rtf).unwrap_or(MAX_STEP_PERIOD);
    *next += period;
    let now = Instant::now();
    let mut overrun = false;
    if now > *next {
        if stepped {
            overrun = true;
            engine.count_overrun();
        }
        if now - *next > period * MAX_CATCH_UP {
            *next = now;
        }
    } else {
        sleep_until(*next, shutdown);
    }
    overrun
}

/// The steps since the last status line: their count, solve time and the simulation time at the
/// line.
pub(crate) struct StatusWindow {
    since: Instant,
    steps: u64,
    sim: f64,
    solve_us: f64,
}

impl StatusWindow {
    /// A window opening now.
    pub(crate) fn new(engine: &Engine) -> Self {
        StatusWindow { since: Instant::now(), steps: 0, sim: engine.scene().world.time(), solve_us: 0.0 }
    }

    /// Counts the step just taken and its islands' solve time.
    pub(crate) fn record_step(&mut self, engine: &Engine) {
        self.steps += 1;
        self.solve_us += engine.scene().world.island_stats().iter().map(|s| s.solve_us).sum::<f64>();
    }

    /// Prints the status line (stderr on a terminal, else the log) once `interval` has passed since
    /// the last, and opens a new window.
    pub(crate) fn report_if_due(
        &mut self,
        interval: Option<Duration>,
        engine: &Engine,
        transports: &mut [Box<dyn Transport>],
    ) {
        if interval.is_none_or(|iv| self.since.elapsed() < iv) {
            return;
        }
        let dt = self.since.elapsed().as_secs_f64();
        let sim = engine.scene().world.time();
        let mut line = format!(
            "t = {sim:8.2} s  rtf {:5.2}  solve {:7.1} µs/step  inputs {} ok / {} rejected{}",
            (sim - self.sim) / dt,
            self.solve_us / self.steps.max(1) as f64,
            engine.health().accepted,
            engine.health().rejected_total(),
            if engine.health().deadman_active { "  DEADMAN" } else { "" },
        );
        for t in transports.iter_mut() {
            line.push_str("  ");
            line.push_str(&t.status());
        }
        if std::io::stderr().is_terminal() {
            eprintln!("{line}");
        } else {
            info!("{line}");
        }
        *self = StatusWindow { since: Instant::now(), steps: 0, sim, solve_us: 0.0 };
    }
}

/// The step period `h / rtf`, or why the real-time factor is refused.
pub fn step_period(timestep: f64, rtf: f64) -> Result<Duration, ServeError> {
    if !(rtf.is_finite() && rtf > 0.0) {
        return Err(ServeError::Option(format!("real-time factor {rtf:e} must be a finite number > 0")));
    }
    match Duration::try_from_secs_f64(timestep / rtf) {
        Ok(p) if p <= MAX_STEP_PERIOD => Ok(p),
        _ => Err(ServeError::Option(format!(
            "real-time factor {rtf:e} gives a step period of {:.3e} s (h = {timestep} s); at most {} s: \
             use a real-time factor of at least {:.3e}",
            timestep / rtf,
            MAX_STEP_PERIOD.as_secs(),
            timestep / MAX_STEP_PERIOD.as_secs_f64()
        ))),
    }
}

/// Sleeps until `deadline` in slices of at most [`MAX_SLEEP`], returning early on shutdown.
pub(crate) fn sleep_until(deadline: Instant, shutdown: &AtomicBool) {
    for _ in 0..=(MAX_STEP_PERIOD.as_millis() / MAX_SLEEP.as_millis()) {
        let now = Instant::now();
        if now >= deadline || shutdown.load(Ordering::Relaxed) {
            return;
        }
        std::thread::sleep((deadline - now).min(MAX_SLEEP));
    }
}
