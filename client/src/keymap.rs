//! Keyboard layout for `drive`, derived from the scene's joystick bindings: each bound axis gets a
//! pair of keys (+/−), each bound button a digit key.
//!
//! Two ways of reading keys, chosen by what the terminal reports:
//! - **hold** (terminals that report key releases, e.g. kitty, foot, WezTerm, recent Alacritty):
//!   an axis is ±1 while its key is held, a button pressed while its key is held;
//! - **lever** (every other terminal, which only reports presses and auto-repeats): each press
//!   moves the axis by ±0.25 like a lever that stays where it is put, a digit toggles its button,
//!   Space centres every axis and releases every button.

use crossterm::event::KeyCode;
use pivotsim_msgs as msgs;

/// Key pairs handed out to axes in order: (+, −).
pub const AXIS_KEYS: [(KeyCode, KeyCode); 12] = [
    (KeyCode::Char('d'), KeyCode::Char('a')),
    (KeyCode::Char('w'), KeyCode::Char('s')),
    (KeyCode::Char('l'), KeyCode::Char('j')),
    (KeyCode::Char('i'), KeyCode::Char('k')),
    (KeyCode::Right, KeyCode::Left),
    (KeyCode::Up, KeyCode::Down),
    (KeyCode::Char('e'), KeyCode::Char('q')),
    (KeyCode::Char('o'), KeyCode::Char('u')),
    (KeyCode::Char('c'), KeyCode::Char('z')),
    (KeyCode::Char('n'), KeyCode::Char('b')),
    (KeyCode::Char('t'), KeyCode::Char('g')),
    (KeyCode::Char('y'), KeyCode::Char('h')),
];

/// Keys handed out to buttons in order.
pub const BUTTON_KEYS: [char; 10] = ['1', '2', '3', '4', '5', '6', '7', '8', '9', '0'];

/// Lever step per key press.
pub const LEVER_STEP: f32 = 0.25;

/// One axis on the keyboard.
#[derive(Debug, Clone, PartialEq)]
pub struct AxisKeys {
    /// Joystick axis index.
    pub axis: u8,
    /// Key for +.
    pub plus: KeyCode,
    /// Key for −.
    pub minus: KeyCode,
    /// What it drives (actuator names).
    pub label: String,
}

/// One button on the keyboard.
#[derive(Debug, Clone, PartialEq)]
pub struct ButtonKey {
    /// Joystick button index.
    pub button: u8,
    /// Key.
    pub key: char,
    /// What it drives.
    pub label: String,
}

/// The keyboard layout of a scene.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Layout {
    /// Axes with keys.
    pub axes: Vec<AxisKeys>,
    /// Buttons with keys.
    pub buttons: Vec<ButtonKey>,
    /// Bound axes or buttons left without a key (more than the keys available).
    pub unmapped: usize,
}

/// A key's display name.
pub fn key_name(k: KeyCode) -> String {
    match k {
        KeyCode::Char(c) => c.to_string(),
        KeyCode::Left => "←".into(),
        KeyCode::Right => "→".into(),
        KeyCode::Up => "↑".into(),
        KeyCode::Down => "↓".into(),
        other => format!("{other:?}"),
    }
}

impl Layout {
    /// Keys for the axes and buttons the scene binds (axes 0–3 when it binds none).
    pub fn from_scene(scene: Option<&msgs::SceneDescription>) -> Layout {
        let bindings = scene.map(|s| s.joystick.as_slice()).unwrap_or(&[]);
        let mut axes: Vec<(u8, Vec<String>)> = Vec::new();
        let mut buttons: Vec<(u8, Vec<String>)> = Vec::new();
        for b in bindings {
            let (list, i) = match b.input {
                msgs::JoystickInput::Axis(i) => (&mut axes, i),
                msgs::JoystickInput::Button(i) => (&mut buttons, i),
            };
            let label = format!("{} {}{}", b.actuator, if b.scale < 0.0 { "−" } else { "" }, b.mode.name());
            match list.iter_mut().find(|(j, _)| *j == i) {
                Some((_, l)) => l.push(label),
                None => list.push((i, vec![label])),
            }
        }
        if bindings.is_empty() {
            axes = (0..4).map(|i| (i, vec![format!("axis {i}")])).collect();
        }
        axes.sort_by_key(|a| a.0);
        buttons.sort_by_key(|b| b.0);
        let unmapped =
            axes.len().saturating_sub(AXIS_KEYS.len()) + buttons.len().saturating_sub(BUTTON_KEYS.len());
        Layout {
            axes: axes
                .into_iter()
                .zip(AXIS_KEYS)
                .map(|((axis, l), (plus, minus))| AxisKeys { axis, plus, minus, label: l.join(" + ") })
                .collect(),
            buttons: buttons
                .into_iter()
                .zip(BUTTON_KEYS)
                .map(|((button, l), key)| ButtonKey { button, key, label: l.join(" + ") })
                .collect(),
            unmapped,
        }
    }

    /// Axes a joystick frame must carry (highest mapped index + 1).
    pub fn axis_count(&self) -> usize {
        self.axes.iter().map(|a| a.axis as usize + 1).max().unwrap_or(0)
    }

    /// Buttons a joystick frame must carry.
    pub fn button_count(&self) -> usize {
        self.buttons.iter().map(|b| b.button as usize + 1).max().unwrap_or(0)
    }

    /// Help lines.
    pub fn help(&self) -> Vec<String> {
        let mut v: Vec<String> = self
            .axes
            .iter()
            .map(|a| format!("{}/{}  axis {:<2} {}", key_name(a.plus), key_name(a.minus), a.axis, a.label))
            .collect();
        v.extend(self.buttons.iter().map(|b| format!("{}    button {:<2} {}", b.key, b.button, b.label)));
        if self.unmapped > 0 {
            v.push(format!("({} more bindings have no key; use a gamepad)", self.unmapped));
        }
        v
    }
}

/// Keyboard state: what the keys say the joystick is.
#[derive(Debug, Clone, PartialEq)]
pub struct KeyState {
    /// Hold mode (releases reported) or lever mode.
    pub hold: bool,
    /// Axis values by joystick index.
    pub axes: [f32; msgs::MAX_AXES],
    /// Button bits.
    pub buttons: u64,
    held_plus: Vec<bool>,
    held_minus: Vec<bool>,
}

/// What a key event was.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum KeyAction {
    /// Pressed (or auto-repeated).
    Press,
    /// Released (hold mode only).
    Release,
}

impl KeyState {
    /// All centred.
    pub fn new(layout: &Layout, hold: bool) -> KeyState {
        KeyState {
            hold,
            axes: [0.0; msgs::MAX_AXES],
            buttons: 0,
            held_plus: vec![false; layout.axes.len()],
            held_minus: vec![false; layout.axes.len()],
        }
    }

    /// Centres every axis and releases every button.
    pub fn centre(&mut self) {
        self.axes = [0.0; msgs::MAX_AXES];
        self.buttons = 0;
        self.held_plus.iter_mut().for_each(|h| *h = false);
        self.held_minus.iter_mut().for_each(|h| *h = false);
    }

    /// Applies a key event; returns whether the key belongs to the layout.
    pub fn key(&mut self, layout: &Layout, code: KeyCode, action: KeyAction, repeat: bool) -> bool {
        let code = match code {
            KeyCode::Char(c) => KeyCode::Char(c.to_ascii_lowercase()),
            c => c,
        };
        if code == KeyCode::Char(' ') {
            if action == KeyAction::Press {
                self.centre();
            }
            return true;
        }
        for (k, a) in layout.axes.iter().enumerate() {
            let sign = if code == a.plus {
                1.0
            } else if code == a.minus {
                -1.0
            } else {
                continue;
            };
            let i = a.axis as usize;
            if self.hold {
                let pressed = action == KeyAction::Press;
                if sign > 0.0 {
                    self.held_plus[k] = pressed;
                } else {
                    self.held_minus[k] = pressed;
                }
                self.axes[i] =
                    f32::from(u8::from(self.held_plus[k])) - f32::from(u8::from(self.held_minus[k]));
            } else if action == KeyAction::Press {
                self.axes[i] = (self.axes[i] + sign * LEVER_STEP).clamp(-1.0, 1.0);
            }
            return true;
        }
        for b in &layout.buttons {
            if code != KeyCode::Char(b.key) {
                continue;
            }
            let bit = 1u64 << b.button;
            if self.hold {
                match action {
                    KeyAction::Press => self.buttons |= bit,
                    KeyAction::Release => self.buttons &= !bit,
                }
            } else if action == KeyAction::Press && !repeat {
                self.buttons ^= bit;
            }
            return true;
        }
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scene() -> msgs::SceneDescription {
        let mut s = msgs::SceneDescription::default();
        for (input, actuator) in [
            (msgs::JoystickInput::Axis(2), "boom"),
            (msgs::JoystickInput::Axis(0), "slew"),
            (msgs::JoystickInput::Axis(0), "other"),
            (msgs::JoystickInput::Button(5), "brake"),
        ] {
            s.joystick.push(msgs::JoystickBinding {
                input,
                actuator: actuator.into(),
                mode: msgs::ActuatorMode::Velocity,
                scale: 1.0,
            });
        }
        s
    }

    #[test]
    fn layout_follows_the_bindings() {
        let l = Layout::from_scene(Some(&scene()));
        assert_eq!(l.axes.len(), 2);
        assert_eq!(l.axes[0].axis, 0);
        assert_eq!(l.axes[0].plus, KeyCode::Char('d'));
        assert_eq!(l.axes[0].label, "slew velocity + other velocity");
        assert_eq!(l.axes[1].axis, 2);
        assert_eq!(l.buttons[0].button, 5);
        assert_eq!(l.buttons[0].key, '1');
        assert_eq!((l.axis_count(), l.button_count()), (3, 6));
        assert_eq!(Layout::from_scene(None).axes.len(), 4);
    }

    #[test]
    fn lever_mode_steps_and_centres() {
        let l = Layout::from_scene(Some(&scene()));
        let mut k = KeyState::new(&l, false);
        for _ in 0..6 {
            assert!(k.key(&l, KeyCode::Char('d'), KeyAction::Press, false));
        }
        assert_eq!(k.axes[0], 1.0);
        k.key(&l, KeyCode::Char('s'), KeyAction::Press, false);
        assert_eq!(k.axes[2], -0.25);
        k.key(&l, KeyCode::Char('1'), KeyAction::Press, false);
        assert_eq!(k.buttons, 1 << 5);
        k.key(&l, KeyCode::Char('1'), KeyAction::Press, true);
        assert_eq!(k.buttons, 1 << 5, "auto-repeat does not toggle");
        k.key(&l, KeyCode::Char(' '), KeyAction::Press, false);
        assert_eq!((k.axes[0], k.axes[2], k.buttons), (0.0, 0.0, 0));
        assert!(!k.key(&l, KeyCode::Char('x'), KeyAction::Press, false));
    }

    #[test]
    fn hold_mode_follows_press_and_release() {
        let l = Layout::from_scene(Some(&scene()));
        let mut k = KeyState::new(&l, true);
        k.key(&l, KeyCode::Char('a'), KeyAction::Press, false);
        assert_eq!(k.axes[0], -1.0);
        k.key(&l, KeyCode::Char('d'), KeyAction::Press, false);
        assert_eq!(k.axes[0], 0.0);
        k.key(&l, KeyCode::Char('a'), KeyAction::Release, false);
        assert_eq!(k.axes[0], 1.0);
        k.key(&l, KeyCode::Char('d'), KeyAction::Release, false);
        assert_eq!(k.axes[0], 0.0);
        k.key(&l, KeyCode::Char('1'), KeyAction::Press, false);
        assert_eq!(k.buttons, 1 << 5);
        k.key(&l, KeyCode::Char('1'), KeyAction::Release, false);
        assert_eq!(k.buttons, 0);
    }
}
