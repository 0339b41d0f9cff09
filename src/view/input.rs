//! What the user asked for in one frame, whether it came from the window or
//! from a script, and the key map that turns it into actions.

use crate::render::Mode;
use minifb::Key;
use std::path::PathBuf;

/// One frame's input, gathered before the frame is rendered.
#[derive(Debug, Default, Clone)]
pub struct FrameInput {
    /// Keys that went down this frame.
    pub pressed: Vec<Key>,
    /// Keys held during this frame (pressed ones included).
    pub held: Vec<Key>,
    /// Mouse drag with the left button, in pixels (x right, y down).
    pub drag: (f32, f32),
    /// Scroll wheel notches, positive away from the user.
    pub scroll: f32,
    /// Script only: screenshots to write after this frame is shown.
    pub screenshots: Vec<PathBuf>,
    /// Script only: render at this size from now on.
    pub resize: Option<(u32, u32)>,
    /// Script only: close the window.
    pub quit: bool,
}

/// A discrete command, triggered when its key goes down.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Action {
    Mode(Mode),
    ToggleDenoise,
    /// Per-frame jitter and the temporal resolve (TAA) on / off.
    ToggleTaa,
    /// The next visibility rate (full, quarter).
    CycleVisibility,
    FewerSamples,
    MoreSamples,
    Faster,
    Slower,
    Screenshot,
    Reset,
    Help,
    Overlay,
    Quit,
}

/// The key help, as shown by `H` (and in the README).
pub const HELP: &[&str] = &[
    "WASD Q/E   MOVE     DRAG/ARROWS  LOOK",
    "SCROLL + - SPEED    1-5  MODE",
    "1 RATIO 2 STOCHASTIC 3 SOFT-SHADOW",
    "4 UNSHADOWED 5 REFERENCE",
    "N (SHIFT+D) DENOISER  T TAA",
    "V VISIBILITY RATE (FULL, QUARTER)",
    "[ ] SPP",
    "P SCREENSHOT  R RESET  O OVERLAY",
    "H HELP  ESC QUIT",
];

impl FrameInput {
    fn is_held(&self, key: Key) -> bool {
        self.held.contains(&key)
    }

    fn shift(&self) -> bool {
        self.is_held(Key::LeftShift) || self.is_held(Key::RightShift)
    }

    /// The actions of the keys that went down this frame, in order.
    pub fn actions(&self) -> Vec<Action> {
        let shift = self.shift();
        let mut actions: Vec<Action> = self
            .pressed
            .iter()
            .filter_map(|&k| action_of(k, shift))
            .collect();
        let notches = self.scroll.round() as i32;
        let step = if notches > 0 {
            Action::Faster
        } else {
            Action::Slower
        };
        actions.extend(std::iter::repeat_n(step, notches.unsigned_abs() as usize));
        actions
    }

    /// Held movement as (right, up, forward), each in -1..=1. Shift turns
    /// the letter keys into commands (Shift+D toggles the denoiser), so it
    /// stops translation.
    pub fn travel(&self) -> (f32, f32, f32) {
        if self.shift() {
            return (0.0, 0.0, 0.0);
        }
        (
            self.axis(Key::D, Key::A),
            self.axis(Key::E, Key::Q),
            self.axis(Key::W, Key::S),
        )
    }

    /// Held arrow keys as (yaw, pitch) rates, each in -1..=1.
    pub fn turn(&self) -> (f32, f32) {
        (
            self.axis(Key::Right, Key::Left),
            self.axis(Key::Up, Key::Down),
        )
    }

    fn axis(&self, plus: Key, minus: Key) -> f32 {
        self.is_held(plus) as i32 as f32 - self.is_held(minus) as i32 as f32
    }
}

/// The key map.
fn action_of(key: Key, shift: bool) -> Option<Action> {
    Some(match key {
        Key::Key1 => Action::Mode(Mode::Ratio),
        Key::Key2 => Action::Mode(Mode::Stochastic),
        Key::Key3 => Action::Mode(Mode::SoftShadow),
        Key::Key4 => Action::Mode(Mode::Unshadowed),
        Key::Key5 => Action::Mode(Mode::Reference),
        Key::N => Action::ToggleDenoise,
        Key::D if shift => Action::ToggleDenoise,
        Key::T => Action::ToggleTaa,
        Key::V => Action::CycleVisibility,
        Key::LeftBracket => Action::FewerSamples,
        Key::RightBracket => Action::MoreSamples,
        Key::Equal | Key::NumPadPlus => Action::Faster,
        Key::Minus | Key::NumPadMinus => Action::Slower,
        Key::P => Action::Screenshot,
        Key::R => Action::Reset,
        Key::H => Action::Help,
        Key::O => Action::Overlay,
        Key::Escape => Action::Quit,
        _ => return None,
    })
}

/// A key by the name a script uses: a letter or digit, or one of
/// `esc up down left right shift [ ] + -`.
pub fn key_named(name: &str) -> Option<Key> {
    const LETTERS: [Key; 26] = [
        Key::A,
        Key::B,
        Key::C,
        Key::D,
        Key::E,
        Key::F,
        Key::G,
        Key::H,
        Key::I,
        Key::J,
        Key::K,
        Key::L,
        Key::M,
        Key::N,
        Key::O,
        Key::P,
        Key::Q,
        Key::R,
        Key::S,
        Key::T,
        Key::U,
        Key::V,
        Key::W,
        Key::X,
        Key::Y,
        Key::Z,
    ];
    const DIGITS: [Key; 10] = [
        Key::Key0,
        Key::Key1,
        Key::Key2,
        Key::Key3,
        Key::Key4,
        Key::Key5,
        Key::Key6,
        Key::Key7,
        Key::Key8,
        Key::Key9,
    ];
    let lower = name.to_ascii_lowercase();
    let mut chars = lower.chars();
    if let (Some(c), None) = (chars.next(), chars.next()) {
        if c.is_ascii_lowercase() {
            return Some(LETTERS[(c as u8 - b'a') as usize]);
        }
        if c.is_ascii_digit() {
            return Some(DIGITS[(c as u8 - b'0') as usize]);
        }
    }
    Some(match lower.as_str() {
        "esc" | "escape" => Key::Escape,
        "up" => Key::Up,
        "down" => Key::Down,
        "left" => Key::Left,
        "right" => Key::Right,
        "shift" => Key::LeftShift,
        "[" => Key::LeftBracket,
        "]" => Key::RightBracket,
        "+" => Key::Equal,
        "-" => Key::Minus,
        _ => return None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pressing(keys: &[Key]) -> FrameInput {
        FrameInput {
            pressed: keys.to_vec(),
            held: keys.to_vec(),
            ..FrameInput::default()
        }
    }

    #[test]
    fn number_keys_pick_the_five_modes_in_order() {
        let keys = [Key::Key1, Key::Key2, Key::Key3, Key::Key4, Key::Key5];
        let modes: Vec<_> = pressing(&keys).actions();
        let expected: Vec<_> = Mode::ALL.iter().map(|&m| Action::Mode(m)).collect();
        assert_eq!(modes, expected);
    }

    #[test]
    fn d_moves_right_and_shift_d_toggles_the_denoiser() {
        let d = pressing(&[Key::D]);
        assert_eq!(d.travel(), (1.0, 0.0, 0.0));
        assert!(d.actions().is_empty());
        let shift_d = pressing(&[Key::LeftShift, Key::D]);
        assert_eq!(shift_d.travel(), (0.0, 0.0, 0.0));
        assert_eq!(shift_d.actions(), [Action::ToggleDenoise]);
        assert_eq!(pressing(&[Key::N]).actions(), [Action::ToggleDenoise]);
    }

    #[test]
    fn t_toggles_jitter_and_resolve() {
        assert_eq!(pressing(&[Key::T]).actions(), [Action::ToggleTaa]);
    }

    #[test]
    fn scroll_notches_become_speed_steps() {
        let up = FrameInput {
            scroll: 2.0,
            ..FrameInput::default()
        };
        assert_eq!(up.actions(), [Action::Faster, Action::Faster]);
        let down = FrameInput {
            scroll: -1.0,
            ..FrameInput::default()
        };
        assert_eq!(down.actions(), [Action::Slower]);
    }

    #[test]
    fn script_key_names_cover_every_bound_key() {
        for name in "abcdefghijklmnopqrstuvwxyz0123456789".chars() {
            assert!(key_named(&name.to_string()).is_some(), "{name}");
        }
        assert_eq!(key_named("W"), Some(Key::W));
        assert_eq!(key_named("7"), Some(Key::Key7));
        assert_eq!(key_named("]"), Some(Key::RightBracket));
        assert_eq!(key_named("Esc"), Some(Key::Escape));
        assert_eq!(key_named("f13"), None);
    }
}
