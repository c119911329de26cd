//! `drive`: joystick frames from the keyboard (terminal raw mode, keys from the scene's joystick
//! bindings, see `keymap.rs`) and/or a gamepad (gilrs, cargo feature `gamepad`), sent at `--rate`
//! Hz (default 50) with an increasing sequence and a random source id. When the console stops
//! sending (Esc, Ctrl-C, end of `--duration`), the server's deadman returns the actuators to
//! neutral 250 ms later.
//!
//! `--axes a,b,… [--buttons BITS]` drives a constant state without keyboard or gamepad (scripts,
//! tests); bound it with `--duration`.
//!
//! Gamepad mapping (the standard layout): axes 0 left stick x, 1 left stick y, 2 right stick x,
//! 3 right stick y, 4 left trigger, 5 right trigger, 6 d-pad x, 7 d-pad y; buttons 0 south (A),
//! 1 east (B), 2 north (Y), 3 west (X), 4 left bumper, 5 right bumper, 6 left trigger, 7 right
//! trigger, 8 select, 9 start, 10 mode, 11 left stick, 12 right stick, 13–16 d-pad up, down,
//! left, right. Keyboard and gamepad add up (clamped to [−1, 1]).

use std::io::{IsTerminal, Write};
use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::{Result, anyhow, bail};
use crossterm::event::{Event, KeyCode, KeyEventKind, KeyModifiers};
use pivotsim_msgs as msgs;
use pivotsim_msgs::Topic;

use crate::common::Common;
use crate::keymap::{KeyAction, KeyState, Layout, key_name};
use crate::net::{InputSink, Stream, TransportKind, now_ns};
use crate::stop::{interrupt, interrupted, secs};

/// `drive` options.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Transport to send on.
    #[arg(long, value_enum, default_value = "zenoh")]
    pub transport: TransportKind,
    /// Frames per second.
    #[arg(long, default_value_t = 50.0, value_name = "HZ")]
    pub rate: f64,
    /// Stop after this many seconds.
    #[arg(long, value_name = "SECONDS")]
    pub duration: Option<f64>,
    /// Constant axes instead of keyboard and gamepad (comma-separated, axis 0 first).
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true, value_name = "A,B,…")]
    pub axes: Vec<f32>,
    /// Constant buttons (bit mask) with `--axes`.
    #[arg(long, default_value_t = 0, value_name = "BITS")]
    pub buttons: u64,
    /// Lever keys (each press moves an axis by 0.25) even if the terminal reports releases.
    #[arg(long)]
    pub lever: bool,
    /// Ignore gamepads.
    #[arg(long)]
    pub no_gamepad: bool,
    /// Source id (default: random).
    #[arg(long, value_name = "ID")]
    pub source_id: Option<u32>,
}

/// Restores the terminal when dropped.
struct RawTerminal {
    enhanced: bool,
}

impl RawTerminal {
    fn enter(want_releases: bool) -> Result<RawTerminal> {
        crossterm::terminal::enable_raw_mode()?;
        let mut t = RawTerminal { enhanced: false };
        if want_releases && crossterm::terminal::supports_keyboard_enhancement().unwrap_or(false) {
            use crossterm::event::{KeyboardEnhancementFlags as F, PushKeyboardEnhancementFlags};
            crossterm::execute!(
                std::io::stdout(),
                PushKeyboardEnhancementFlags(F::REPORT_EVENT_TYPES | F::DISAMBIGUATE_ESCAPE_CODES)
            )?;
            t.enhanced = true;
        }
        Ok(t)
    }
}

impl Drop for RawTerminal {
    fn drop(&mut self) {
        if self.enhanced {
            let _ = crossterm::execute!(std::io::stdout(), crossterm::event::PopKeyboardEnhancementFlags);
        }
        let _ = crossterm::terminal::disable_raw_mode();
    }
}

#[cfg(feature = "gamepad")]
mod pad {
    use gilrs::{Axis, Button, Gilrs};

    pub const AXES: [Axis; 8] = [
        Axis::LeftStickX,
        Axis::LeftStickY,
        Axis::RightStickX,
        Axis::RightStickY,
        Axis::LeftZ,
        Axis::RightZ,
        Axis::DPadX,
        Axis::DPadY,
    ];
    pub const BUTTONS: [Button; 17] = [
        Button::South,
        Button::East,
        Button::North,
        Button::West,
        Button::LeftTrigger,
        Button::RightTrigger,
        Button::LeftTrigger2,
        Button::RightTrigger2,
        Button::Select,
        Button::Start,
        Button::Mode,
        Button::LeftThumb,
        Button::RightThumb,
        Button::DPadUp,
        Button::DPadDown,
        Button::DPadLeft,
        Button::DPadRight,
    ];
    const DEADZONE: f32 = 0.05;

    pub struct Pad {
        gilrs: Gilrs,
    }

    impl Pad {
        /// gilrs, if it starts (no udev, no permissions: `None`).
        pub fn open() -> Option<Pad> {
            Gilrs::new().ok().map(|gilrs| Pad { gilrs })
        }

        /// Name of the first connected gamepad.
        pub fn name(&self) -> Option<String> {
            self.gilrs.gamepads().find(|(_, g)| g.is_connected()).map(|(_, g)| g.name().to_string())
        }

        /// Axes and buttons of the first connected gamepad (events drained first).
        pub fn read(&mut self) -> Option<([f32; 8], u64)> {
            while self.gilrs.next_event().is_some() {}
            let (_, g) = self.gilrs.gamepads().find(|(_, g)| g.is_connected())?;
            let mut axes = [0.0f32; 8];
            for (v, a) in axes.iter_mut().zip(AXES) {
                let x = g.value(a);
                *v = if x.is_finite() && x.abs() >= DEADZONE { x.clamp(-1.0, 1.0) } else { 0.0 };
            }
            let mut buttons = 0u64;
            for (i, b) in BUTTONS.iter().enumerate() {
                if g.is_pressed(*b) {
                    buttons |= 1 << i;
                }
            }
            Some((axes, buttons))
        }
    }
}

#[cfg(not(feature = "gamepad"))]
mod pad {
    pub struct Pad;

    impl Pad {
        pub fn open() -> Option<Pad> {
            None
        }

        pub fn name(&self) -> Option<String> {
            None
        }

        pub fn read(&mut self) -> Option<([f32; 8], u64)> {
            None
        }
    }
}

fn bar(v: f32) -> String {
    let n = 5;
    let k = (v.abs() * n as f32).round() as usize;
    let (l, r) = if v < 0.0 {
        (format!("{}{}", " ".repeat(n - k), "=".repeat(k)), " ".repeat(n))
    } else {
        (" ".repeat(n), format!("{}{}", "=".repeat(k), " ".repeat(n - k)))
    };
    format!("[{l}|{r}]")
}

/// Checks `--axes` before anything connects.
fn check_axes(args: &Args) -> Result<()> {
    if args.axes.len() > msgs::MAX_AXES {
        bail!("{} axes (at most {})", args.axes.len(), msgs::MAX_AXES);
    }
    if args.axes.iter().any(|a| !(a.is_finite() && (-1.0..=1.0).contains(a))) {
        bail!("axis values must be in [-1, 1]");
    }
    Ok(())
}

/// The drive loop's state: what is pressed, where the frames go, what was sent.
struct Driver<'a> {
    args: &'a Args,
    layout: Layout,
    keys: KeyState,
    pad: Option<pad::Pad>,
    scripted: bool,
    use_keys: bool,
    axis_count: usize,
    button_count: usize,
    source: u32,
    seq: u64,
    sink: InputSink,
    link: Option<crate::net::ZenohLink>,
    timeout: Duration,
    stats: Option<Stream>,
    server: String,
    buf: Vec<u8>,
    sent: u64,
    errors: u64,
    nl: &'static str,
}

impl Driver<'_> {
    /// The start lines: scene, world, transport, source, gamepad, key help.
    fn banner(
        &self,
        scene: Option<&msgs::SceneDescription>,
        world: &msgs::WorldName,
        pad: Option<&str>,
    ) -> Result<()> {
        let nl = self.nl;
        let mut out = std::io::stdout().lock();
        let scene_name = scene.map_or("?", |s| s.scene.as_str());
        write!(
            out,
            "driving scene `{scene_name}` (world `{world}`) via {:?}, source {:#010x}{nl}",
            self.args.transport, self.source
        )?;
        if let Some(n) = pad {
            write!(out, "gamepad: {n}{nl}")?;
        }
        if self.use_keys {
            let mode = if self.keys.hold { "hold keys" } else { "lever keys: each press moves 0.25" };
            write!(out, "keyboard ({mode}); Space centres, Esc or Ctrl-C quits{nl}")?;
            for l in self.layout.help() {
                write!(out, "  {l}{nl}")?;
            }
        }
        out.flush()?;
        Ok(())
    }

    /// Reads keys until `next` (or sleeps until it); `true` when the operator quits.
    fn read_keys_until(&mut self, next: Instant) -> Result<bool> {
        if !self.use_keys {
            std::thread::sleep(next.saturating_duration_since(Instant::now()));
            return Ok(false);
        }
        while crossterm::event::poll(next.saturating_duration_since(Instant::now()))? {
            if let Event::Key(k) = crossterm::event::read()? {
                let ctrl_c = k.code == KeyCode::Char('c') && k.modifiers.contains(KeyModifiers::CONTROL);
                if k.code == KeyCode::Esc || ctrl_c {
                    interrupt();
                    return Ok(true);
                }
                let action =
                    if k.kind == KeyEventKind::Release { KeyAction::Release } else { KeyAction::Press };
                self.keys.key(&self.layout, k.code, action, k.kind == KeyEventKind::Repeat);
            }
            if Instant::now() >= next {
                break;
            }
        }
        Ok(false)
    }

    /// The state to send: constant (`--axes`), or keyboard + gamepad.
    fn state(&mut self) -> ([f32; msgs::MAX_AXES], u64) {
        let mut axes = [0.0f32; msgs::MAX_AXES];
        let mut buttons;
        if self.scripted {
            axes[..self.args.axes.len()].copy_from_slice(&self.args.axes);
            buttons = self.args.buttons;
        } else {
            axes = self.keys.axes;
            buttons = self.keys.buttons;
            if let Some((pa, pb)) = self.pad.as_mut().and_then(|p| p.read()) {
                for (a, p) in axes.iter_mut().zip(pa) {
                    *a = (*a + p).clamp(-1.0, 1.0);
                }
                buttons |= pb;
            }
        }
        if self.button_count < 64 {
            buttons &= (1u64 << self.button_count) - 1;
        }
        (axes, buttons)
    }

    /// Encodes and sends one joystick frame; an error ends the run only while nothing got through.
    fn send(&mut self, axes: &[f32; msgs::MAX_AXES], buttons: u64) -> Result<()> {
        self.seq += 1;
        let j = msgs::Joystick::new(
            self.seq,
            self.source,
            &axes[..self.axis_count],
            buttons,
            self.button_count as u8,
        )
        .ok_or_else(|| anyhow!("joystick state"))?;
        msgs::InputCommand::Joystick(j).encode(&mut self.buf).map_err(|e| anyhow!("joystick: {e}"))?;
        match self.sink.send(self.link.as_ref(), Topic::Joystick, &self.buf, self.timeout) {
            Ok(()) => self.sent += 1,
            Err(e) => {
                self.errors += 1;
                if self.errors == 1 {
                    eprint!("pivotsim-client: {e:#}{}", self.nl);
                }
                if self.sent == 0 && self.errors >= 3 {
                    return Err(e);
                }
            }
        }
        Ok(())
    }

    /// The server's input counters from the newest stats frames (best effort).
    fn read_server_counters(&mut self) {
        let Some(s) = &self.stats else { return };
        while let Some(r) = s.inbox.try_recv() {
            if let Ok(st) = msgs::SolverStats::decode(&r.bytes) {
                self.server = format!(
                    "server: accepted {} rejected {}{}",
                    st.inputs.accepted,
                    st.inputs.rejected_total(),
                    if st.inputs.deadman_active { " DEADMAN" } else { "" }
                );
            }
        }
    }

    /// The status line under the help (raw terminal only).
    fn draw_status(&self, axes: &[f32; msgs::MAX_AXES], buttons: u64) -> Result<()> {
        let shown: Vec<String> = self
            .layout
            .axes
            .iter()
            .map(|a| format!("{}{}{}", key_name(a.plus), bar(axes[a.axis as usize]), key_name(a.minus)))
            .collect();
        let mut out = std::io::stdout().lock();
        write!(
            out,
            "\r{}  buttons {:#x}  sent {}  {}\x1b[K",
            shown.join(" "),
            buttons,
            self.sent,
            self.server
        )?;
        out.flush()?;
        Ok(())
    }

    /// Sends at the period until the end, Esc or Ctrl-C.
    fn drive(&mut self, period: Duration, end: Option<Instant>, raw: bool) -> Result<()> {
        let mut next = Instant::now();
        let mut last_status = Instant::now();
        loop {
            if interrupted() || end.is_some_and(|e| Instant::now() >= e) {
                return Ok(());
            }
            if self.read_keys_until(next)? {
                return Ok(());
            }
            next += period;
            if next < Instant::now() {
                next = Instant::now() + period;
            }
            let (axes, buttons) = self.state();
            self.send(&axes, buttons)?;
            self.read_server_counters();
            if raw && last_status.elapsed() >= Duration::from_millis(100) {
                last_status = Instant::now();
                self.draw_status(&axes, buttons)?;
            }
        }
    }
}

/// Runs `drive`: checks, the link and the scene, the sink, the terminal, the banner, then the loop.
pub fn run(common: &Common, args: &Args) -> Result<ExitCode> {
    let timeout = common.timeout_or(5.0);
    let world = common.world()?;
    let scripted = !args.axes.is_empty();
    check_axes(args)?;
    let (link, scene) = crate::util::input_link(common, args.transport, timeout)?;
    let layout = Layout::from_scene(scene.as_ref());
    let pad = if scripted || args.no_gamepad { None } else { pad::Pad::open() };
    let pad_name = pad.as_ref().and_then(|p| p.name());
    let tty = std::io::stdin().is_terminal() && std::io::stdout().is_terminal();
    if !scripted && !tty && pad_name.is_none() {
        bail!("drive needs a terminal (keyboard), a gamepad, or --axes");
    }
    let sink = InputSink::open(args.transport, &world, timeout)?;
    // Stats for the status line (best effort).
    let stats = common
        .server()
        .and_then(|s| Stream::open(&s, args.transport, &[Topic::Stats], 64, Duration::from_millis(2), None))
        .ok();
    let use_keys = !scripted && tty;
    let mut keys = KeyState::new(&layout, false);
    let raw = if use_keys {
        let t = RawTerminal::enter(!args.lever)?;
        keys.hold = t.enhanced;
        Some(t)
    } else {
        None
    };
    let axis_count = if scripted {
        args.axes.len()
    } else {
        layout.axis_count().max(if pad_name.is_some() { 8 } else { 0 }).max(1)
    };
    let button_count = if scripted {
        (64 - args.buttons.leading_zeros()) as usize
    } else {
        layout.button_count().max(if pad_name.is_some() { 17 } else { 0 })
    };
    let mut d = Driver {
        args,
        layout,
        keys,
        pad,
        scripted,
        use_keys,
        axis_count,
        button_count,
        source: args.source_id.unwrap_or_else(crate::util::random_u32),
        seq: now_ns(),
        sink,
        link,
        timeout,
        stats,
        server: String::new(),
        buf: Vec::new(),
        sent: 0,
        errors: 0,
        nl: if raw.is_some() { "\r\n" } else { "\n" },
    };
    d.banner(scene.as_ref(), &world, pad_name.as_deref())?;
    let period = secs(1.0 / args.rate.clamp(1.0, 200.0));
    let end = args.duration.map(|t| Instant::now() + secs(t));
    let result = d.drive(period, end, raw.is_some());
    drop(raw);
    println!(
        "{}sent {} joystick frames as source {:#010x} ({} send errors)",
        if use_keys { "\n" } else { "" },
        d.sent,
        d.source,
        d.errors
    );
    result?;
    Ok(ExitCode::SUCCESS)
}
