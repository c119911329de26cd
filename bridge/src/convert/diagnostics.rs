//! `/pivotsim/diagnostics`: the solver, inputs, signals and bridge health as `diagnostic_msgs`.

use super::*;

pub(super) fn kv(key: impl Into<String>, value: impl ToString) -> KeyValue {
    KeyValue { key: key.into(), value: value.to_string() }
}

/// Name of the solver status in `/pivotsim/diagnostics`.
pub const DIAG_SOLVER: &str = "pivotsim: solver";
/// Name of the server's input status in `/pivotsim/diagnostics`.
pub const DIAG_INPUTS: &str = "pivotsim: inputs";
/// Name of the signals status in `/pivotsim/diagnostics`: every channel `{sensor}/{channel}` → value.
pub const DIAG_SIGNALS: &str = "pivotsim: signals";
/// Name of the bridge's own status in `/pivotsim/diagnostics`.
pub const DIAG_BRIDGE: &str = "pivotsim-ros2-bridge";

/// What the bridge reports about itself.
#[derive(Debug, Clone, Default)]
pub struct BridgeHealth {
    /// World name.
    pub world: String,
    /// Scene name, once described.
    pub scene: Option<String>,
    /// Pose frames received over Zenoh.
    pub pose_frames: u64,
    /// Pose frames replaced before the ROS side took them (latest wins).
    pub pose_frames_skipped: u64,
    /// Seconds since the last frame from the server (`None`: none yet).
    pub server_silent_s: Option<f64>,
    /// ROS publishes that failed (would block, I/O).
    pub ros_publish_failed: u64,
    /// `/joy` counters.
    pub joy: JoyCounters,
    /// Joystick source id of the bridge.
    pub source_id: u32,
    /// Signals and events counters.
    pub signals: SignalCounters,
}

/// Counters of the signals and events path (bridge side).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SignalCounters {
    /// Signals frames received over Zenoh.
    pub signals_frames: u64,
    /// Signals frames replaced before the ROS side took them (latest wins).
    pub signals_frames_skipped: u64,
    /// Signals frames that did not decode (counted, dropped).
    pub signals_decode_failed: u64,
    /// Events frames received over Zenoh.
    pub events_frames: u64,
    /// Events frames dropped because the bridge's queue of them was full.
    pub events_frames_dropped: u64,
    /// Events frames that did not decode.
    pub events_decode_failed: u64,
    /// Events published on `/rosout`.
    pub events_logged: u64,
    /// Wrench topics (one per force sensor) that exist.
    pub wrench_topics: u64,
    /// Force sensors without a topic (beyond [`MAX_WRENCH_TOPICS`], or whose publisher failed).
    pub wrench_sensors_refused: u64,
}

/// `/pivotsim/diagnostics`: the server's solver and input statistics (from its latest stats frame, if
/// any), its sensor channels (from its latest signals frame, if any) and the bridge's own counters.
pub fn diagnostics(
    stats: Option<&msgs::SolverStats>,
    signals: Option<&msgs::SignalsFrame>,
    bridge: &BridgeHealth,
    stamp: Time,
) -> DiagnosticArray {
    let mut status = Vec::new();
    let hw = format!("pivotsim/{}", bridge.world);
    if let Some(s) = stats {
        let t = &s.totals;
        status.push(DiagnosticStatus {
            level: DiagnosticStatus::OK,
            name: DIAG_SOLVER.into(),
            message: format!("step {} at t = {:.3} s, {} islands", s.sequence, s.sim_time, s.islands.len()),
            hardware_id: hw.clone(),
            values: vec![
                kv("sequence", s.sequence),
                kv("sim_time_s", s.sim_time),
                kv("step_wall_us", s.step_wall_us),
                kv("overruns", s.overruns),
                kv("islands", s.islands.len()),
                kv("rows", t.rows),
                kv("bodies", t.bodies),
                kv("tight", t.tight),
                kv("fallback_islands", t.fallback_islands),
                kv("pivot_steps", t.pivot_steps),
                kv("solve_us", t.solve_us),
                kv("max_residual_rel", t.residual_rel_max),
            ],
        });
        let h = &s.inputs;
        let mut values = vec![kv("accepted", h.accepted), kv("rejected", h.rejected_total())];
        for r in msgs::RejectReason::ALL {
            values.push(kv(format!("rejected.{}", r.name()), h.rejected_for(*r)));
        }
        values.push(kv("deadman_trips", h.deadman_trips));
        values.push(kv("deadman_active", h.deadman_active));
        status.push(DiagnosticStatus {
            level: DiagnosticStatus::OK,
            name: DIAG_INPUTS.into(),
            message: if h.deadman_active {
                "deadman: actuators at neutral".into()
            } else {
                "operator input live".into()
            },
            hardware_id: hw.clone(),
            values,
        });
    }
    if let Some(f) = signals {
        let dropouts = f.channels.iter().filter(|c| c.dropout).count();
        let mut values = vec![kv("sequence", f.sequence), kv("sim_time_s", f.sim_time)];
        values.extend(
            f.channels
                .iter()
                .map(|c| kv(c.name.as_str(), if c.dropout { "dropout".into() } else { c.value.to_string() })),
        );
        values.push(kv("contacts", f.contacts.len()));
        for (key, state) in
            [("contacts_stick", msgs::ContactCode::Stick), ("contacts_slip", msgs::ContactCode::Slip)]
        {
            values.push(kv(key, f.contacts.iter().filter(|c| c.state == state).count()));
        }
        values.push(kv("dropout_count", dropouts));
        values.push(kv("events_total", f.events_total));
        values.push(kv("faults_applied", f.faults_applied));
        values.push(kv("faults_rejected", f.faults_rejected));
        status.push(DiagnosticStatus {
            level: if dropouts > 0 { DiagnosticStatus::WARN } else { DiagnosticStatus::OK },
            name: DIAG_SIGNALS.into(),
            message: if dropouts > 0 {
                format!("{} channels, {dropouts} dropped out", f.channels.len())
            } else {
                format!("{} channels, {} contacts", f.channels.len(), f.contacts.len())
            },
            hardware_id: hw.clone(),
            values,
        });
    }
    let j = &bridge.joy;
    let stale = bridge.server_silent_s.is_none_or(|s| s > 1.0);
    let mut values = vec![
        kv("world", &bridge.world),
        kv("scene", bridge.scene.as_deref().unwrap_or("")),
        kv(
            "server_silent_s",
            bridge.server_silent_s.map_or("never heard".to_string(), |s| format!("{s:.3}")),
        ),
        kv("pose_frames", bridge.pose_frames),
        kv("pose_frames_skipped", bridge.pose_frames_skipped),
        kv("ros_publish_failed", bridge.ros_publish_failed),
        kv("joy_source_id", bridge.source_id),
        kv("joy_received", j.received),
        kv("joy_forwarded", j.forwarded),
        kv("joy_put_failed", j.put_failed),
        kv("joy_rejected", j.rejected_total()),
    ];
    for r in msgs::RejectReason::ALL {
        values.push(kv(format!("joy_rejected.{}", r.name()), j.rejected_for(*r)));
    }
    let g = &bridge.signals;
    values.extend([
        kv("signals_frames", g.signals_frames),
        kv("signals_frames_skipped", g.signals_frames_skipped),
        kv("signals_decode_failed", g.signals_decode_failed),
        kv("events_frames", g.events_frames),
        kv("events_frames_dropped", g.events_frames_dropped),
        kv("events_decode_failed", g.events_decode_failed),
        kv("events_logged", g.events_logged),
        kv("wrench_topics", g.wrench_topics),
        kv("wrench_sensors_refused", g.wrench_sensors_refused),
    ]);
    status.push(DiagnosticStatus {
        level: if stale { DiagnosticStatus::STALE } else { DiagnosticStatus::OK },
        name: DIAG_BRIDGE.into(),
        message: if stale { "no frames from the server".into() } else { "bridging".into() },
        hardware_id: hw,
        values,
    });
    DiagnosticArray { header: Header { stamp, frame_id: String::new() }, status }
}
