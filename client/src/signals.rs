//! `watch --signals`: the server's sensor channels (rope tensions, joint reactions, contact sums,
//! the tipping margin, cylinder forces), the contact states and the events, live. On a terminal a
//! table redrawn in place (at most 10 times a second) with the last events under it; otherwise (or
//! with `--plain`) one line per step and one per event; `--json` one object per frame.

use std::io::{IsTerminal, Write};
use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::{Result, bail};
use pivotsim_msgs as msgs;
use pivotsim_msgs::Topic;

use crate::common::Common;
use crate::net::{Stream, TransportKind};
use crate::stop::{interrupted, secs};

/// Events kept under the table.
const EVENT_LINES: usize = 8;

fn event_line(e: &msgs::EventRecord) -> String {
    format!(
        "{:>10.3} s  {:<14} {:<32} value {:.6}  level {:.6}",
        e.time,
        e.kind.name(),
        e.name.as_str(),
        e.value,
        e.level
    )
}

fn signals_json(s: &msgs::SignalsFrame) -> serde_json::Value {
    let channels: serde_json::Map<String, serde_json::Value> = s
        .channels
        .iter()
        .map(|c| {
            let v = if c.dropout { serde_json::Value::Null } else { serde_json::json!(c.value) };
            (c.name.as_str().to_string(), v)
        })
        .collect();
    let contacts: Vec<_> = s
        .contacts
        .iter()
        .map(|c| {
            serde_json::json!({"a": c.body_a, "b": c.body_b, "state": c.state.name(), "point": c.point,
                "normal": c.normal_force, "friction": c.friction_force})
        })
        .collect();
    serde_json::json!({"signals": {"sequence": s.sequence, "sim_time": s.sim_time, "events_total": s.events_total,
        "faults_applied": s.faults_applied, "faults_rejected": s.faults_rejected,
        "channels": channels, "contacts": contacts}})
}

fn table(s: &msgs::SignalsFrame, events: &[String]) -> String {
    let mut t = format!(
        "step {}   sim time {:.3} s   events {}   faults {} applied, {} refused\n\n",
        s.sequence, s.sim_time, s.events_total, s.faults_applied, s.faults_rejected
    );
    for c in &s.channels {
        let v = if c.dropout { "  (dropout)".to_string() } else { format!("{:>16.6}", c.value) };
        t.push_str(&format!("{:<32} {v}\n", c.name.as_str()));
    }
    let count = |k: msgs::ContactCode| s.contacts.iter().filter(|c| c.state == k).count();
    if !s.contacts.is_empty() {
        t.push_str(&format!(
            "\ncontacts {}: stick {}  slip {}  open {}\n",
            s.contacts.len(),
            count(msgs::ContactCode::Stick),
            count(msgs::ContactCode::Slip),
            count(msgs::ContactCode::Open)
        ));
    }
    t.push_str("\nlast events:\n");
    for e in events {
        t.push_str(e);
        t.push('\n');
    }
    t
}

/// What `watch --signals` was asked for (from `watch`'s arguments).
#[derive(Debug, Clone, Copy)]
pub struct View {
    /// Transport to receive on.
    pub transport: TransportKind,
    /// Stop after this many steps.
    pub count: Option<u64>,
    /// Stop after this many seconds.
    pub duration: Option<f64>,
    /// One line per step even on a terminal.
    pub plain: bool,
    /// One JSON object per frame.
    pub json: bool,
}

/// Runs `watch --signals`.
pub fn run(common: &Common, args: &View) -> Result<ExitCode> {
    let tty = std::io::stdout().is_terminal() && !args.plain && !args.json;
    let stream = Stream::open(
        &common.server()?,
        args.transport,
        &[Topic::Signals, Topic::Events],
        1024,
        Duration::from_micros(500),
        None,
    )?;
    let idle = common.timeout.map(secs);
    let end = args.duration.map(|d| Instant::now() + secs(d));
    let mut last_frame = Instant::now();
    let mut last_draw: Option<Instant> = None;
    let mut last_seq = None;
    let mut steps = 0u64;
    let mut malformed = 0u64;
    let mut events: Vec<String> = Vec::new();
    let mut frame = msgs::SignalsFrame::default();
    let mut out = std::io::stdout();
    if tty {
        crossterm::execute!(out, crossterm::terminal::Clear(crossterm::terminal::ClearType::All))?;
    }
    while args.count.is_none_or(|c| steps < c) && !interrupted() && end.is_none_or(|e| Instant::now() < e) {
        if let Some(idle) = idle
            && last_frame.elapsed() >= idle
        {
            bail!("no signals for {:.1} s", idle.as_secs_f64());
        }
        let Some(r) = stream.inbox.recv_timeout(Duration::from_millis(50)) else { continue };
        match r.topic {
            Some(Topic::Events) => match msgs::EventsFrame::decode(&r.bytes) {
                Ok(ev) => {
                    last_frame = Instant::now();
                    for e in &ev.events {
                        if args.json {
                            let j = serde_json::json!({"event": {"sequence": ev.sequence, "kind": e.kind.name(),
                                "name": e.name.as_str(), "time": e.time, "value": e.value, "level": e.level}});
                            writeln!(out, "{j}")?;
                        } else if tty {
                            events.push(event_line(e));
                            if events.len() > EVENT_LINES {
                                events.remove(0);
                            }
                        } else {
                            writeln!(out, "EVENT {}", event_line(e))?;
                        }
                    }
                }
                Err(_) => malformed += 1,
            },
            Some(Topic::Signals) => match frame.decode_into(&r.bytes) {
                Ok(()) => {
                    last_frame = Instant::now();
                    if last_seq == Some(frame.sequence) {
                        continue; // a paused server's re-send
                    }
                    last_seq = Some(frame.sequence);
                    steps += 1;
                    if args.json {
                        writeln!(out, "{}", signals_json(&frame))?;
                    } else if tty {
                        if last_draw.is_none_or(|t| t.elapsed() >= Duration::from_millis(100)) {
                            last_draw = Some(Instant::now());
                            crossterm::queue!(
                                out,
                                crossterm::cursor::MoveTo(0, 0),
                                crossterm::terminal::Clear(crossterm::terminal::ClearType::FromCursorDown)
                            )?;
                            write!(out, "{}", table(&frame, &events).replace('\n', "\r\n"))?;
                            out.flush()?;
                        }
                    } else {
                        let vals: Vec<String> = frame
                            .channels
                            .iter()
                            .map(|c| {
                                if c.dropout {
                                    format!("{}=-", c.name.as_str())
                                } else {
                                    format!("{}={:.6}", c.name.as_str(), c.value)
                                }
                            })
                            .collect();
                        writeln!(out, "{} {:.3} {}", frame.sequence, frame.sim_time, vals.join(" "))?;
                    }
                }
                Err(_) => malformed += 1,
            },
            _ => malformed += 1,
        }
    }
    if malformed > 0 {
        eprintln!("pivotsim-client: {malformed} malformed frame(s) skipped");
    }
    Ok(ExitCode::SUCCESS)
}
