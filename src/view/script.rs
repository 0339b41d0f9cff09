//! `--script FILE`: key and mouse events replayed at given frame numbers, so
//! a window session can be repeated exactly (tests, demos, measurements).
//!
//! One event per line; `#` starts a comment. `frame N` means "after N frames
//! have been shown, before the next is rendered" (`frame 0` acts before the
//! first frame):
//!
//! ```text
//! frame 0  key 2              # tap: the key goes down and up within one frame
//! frame 10 key w down         # held from frame 10 ...
//! frame 20 key w up           # ... to frame 20
//! frame 20 drag 40 -10        # mouse drag with the left button, pixels (x right, y down)
//! frame 25 scroll 2           # wheel notches (speed up; negative slows down)
//! frame 30 screenshot a.png   # the window as shown -> a.png, linear frame -> a.exr
//! frame 30 resize 640 360     # render at a new size from now on
//! frame 40 quit
//! ```
//!
//! Keys are named as in `input::key_named`. Screenshot paths are relative to
//! the script's folder. A script run uses a fixed clock of 1/30 s per frame,
//! so movement does not depend on how fast frames render.

use super::input::{FrameInput, key_named};
use minifb::Key;
use std::path::{Path, PathBuf};

/// Seconds one frame of a script run advances the movement clock.
pub const SCRIPT_DT: f32 = 1.0 / 30.0;

#[derive(Debug, Clone, PartialEq)]
pub enum Event {
    Tap(Key),
    Down(Key),
    Up(Key),
    Drag(f32, f32),
    Scroll(f32),
    Screenshot(PathBuf),
    Resize(u32, u32),
    Quit,
}

/// Events in frame order (lines with the same frame keep their order).
#[derive(Debug, Clone, Default)]
pub struct Script {
    events: Vec<(u32, Event)>,
}

#[derive(Debug, thiserror::Error)]
#[error("{origin}:{line}: {message}")]
pub struct ScriptError {
    origin: String,
    line: usize,
    message: String,
}

impl Script {
    /// Reads and parses a script file.
    pub fn load(path: &Path) -> anyhow::Result<Script> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| anyhow::anyhow!("{}: cannot read the script: {e}", path.display()))?;
        let base = path.parent().unwrap_or(Path::new("."));
        Ok(Script::parse(&text, &path.display().to_string(), base)?)
    }

    /// Parses script text; `origin` names it in errors, `base` is the
    /// folder screenshot paths are relative to.
    pub fn parse(text: &str, origin: &str, base: &Path) -> Result<Script, ScriptError> {
        let mut events = Vec::new();
        for (i, raw) in text.lines().enumerate() {
            let line = raw.split('#').next().unwrap_or("").trim();
            if line.is_empty() {
                continue;
            }
            let err = |message: String| ScriptError {
                origin: origin.to_string(),
                line: i + 1,
                message,
            };
            let words: Vec<&str> = line.split_whitespace().collect();
            let event = parse_event(&words, base).map_err(err)?;
            events.push(event);
        }
        events.sort_by_key(|(frame, _)| *frame);
        Ok(Script { events })
    }

    /// The frame after which the last event happens.
    pub fn last_frame(&self) -> Option<u32> {
        self.events.last().map(|(f, _)| *f)
    }

    pub fn events(&self) -> &[(u32, Event)] {
        &self.events
    }
}

fn parse_event(words: &[&str], base: &Path) -> Result<(u32, Event), String> {
    let [kw, n, rest @ ..] = words else {
        return Err("expected `frame N EVENT`".into());
    };
    if *kw != "frame" {
        return Err(format!("expected `frame N EVENT`, found \"{kw}\""));
    }
    let frame: u32 = n
        .parse()
        .map_err(|_| format!("frame number \"{n}\" is not a whole number >= 0"))?;
    let number = |s: &str, what: &str| -> Result<f32, String> {
        s.parse::<f32>()
            .ok()
            .filter(|v| v.is_finite() && v.abs() <= 1e4)
            .ok_or_else(|| format!("{what} \"{s}\" is not a number in -10000..=10000"))
    };
    let event = match rest {
        ["key", name, state @ ..] => {
            let key = key_named(name).ok_or_else(|| format!("unknown key \"{name}\""))?;
            match state {
                [] => Event::Tap(key),
                ["down"] => Event::Down(key),
                ["up"] => Event::Up(key),
                _ => return Err(format!("key {name}: expected nothing, `down` or `up`")),
            }
        }
        ["drag", dx, dy] => Event::Drag(number(dx, "drag x")?, number(dy, "drag y")?),
        ["scroll", s] => Event::Scroll(number(s, "scroll")?),
        ["screenshot", path] => {
            let p = Path::new(path);
            if !p.extension().is_some_and(|e| e.eq_ignore_ascii_case("png")) {
                return Err(format!(
                    "screenshot {path}: must end in .png (the linear EXR goes beside it)"
                ));
            }
            if frame == 0 {
                return Err("screenshot at frame 0: nothing has been shown yet".into());
            }
            Event::Screenshot(base.join(p))
        }
        ["resize", w, h] => {
            let side = |s: &str| {
                s.parse::<u32>()
                    .ok()
                    .filter(|&v| v > 0)
                    .ok_or_else(|| format!("resize: \"{s}\" is not a size in pixels"))
            };
            let (w, h) = (side(w)?, side(h)?);
            crate::scene::check_resolution(w, h)?;
            Event::Resize(w, h)
        }
        ["quit"] => Event::Quit,
        _ => {
            return Err(format!(
                "unknown event \"{}\" (expected key, drag, scroll, screenshot, resize or quit)",
                rest.join(" ")
            ));
        }
    };
    Ok((frame, event))
}

/// Replays a script into each frame's input; keeps the keys it holds down.
#[derive(Debug, Default)]
pub struct Player {
    script: Script,
    next: usize,
    held: Vec<Key>,
}

impl Player {
    pub fn new(script: Script) -> Player {
        Player {
            script,
            next: 0,
            held: Vec::new(),
        }
    }

    /// Adds the events due once `shown` frames have been shown.
    pub fn feed(&mut self, shown: u32, input: &mut FrameInput) {
        let mut released = Vec::new();
        while let Some((frame, event)) = self.script.events.get(self.next) {
            if *frame > shown {
                break;
            }
            self.next += 1;
            match event {
                Event::Tap(k) => {
                    input.pressed.push(*k);
                    input.held.push(*k);
                }
                Event::Down(k) => {
                    input.pressed.push(*k);
                    if !self.held.contains(k) {
                        self.held.push(*k);
                    }
                }
                Event::Up(k) => released.push(*k),
                Event::Drag(dx, dy) => {
                    input.drag.0 += dx;
                    input.drag.1 += dy;
                }
                Event::Scroll(s) => input.scroll += s,
                Event::Screenshot(p) => input.screenshots.push(p.clone()),
                Event::Resize(w, h) => input.resize = Some((*w, *h)),
                Event::Quit => input.quit = true,
            }
        }
        self.held.retain(|k| !released.contains(k));
        input.held.extend(&self.held);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Script, ScriptError> {
        Script::parse(text, "s.txt", Path::new("/shots"))
    }

    #[test]
    fn events_are_parsed_and_ordered_by_frame() {
        let s = parse(
            "# a flight\nframe 5 key w down\nframe 2 key 2   # mode\n\
             frame 9 key W up\nframe 9 drag 40 -10\nframe 9 scroll -2\n\
             frame 12 screenshot a.png\nframe 12 resize 64 36\nframe 13 quit\n",
        )
        .unwrap();
        let expected = vec![
            (2, Event::Tap(Key::Key2)),
            (5, Event::Down(Key::W)),
            (9, Event::Up(Key::W)),
            (9, Event::Drag(40.0, -10.0)),
            (9, Event::Scroll(-2.0)),
            (12, Event::Screenshot(PathBuf::from("/shots/a.png"))),
            (12, Event::Resize(64, 36)),
            (13, Event::Quit),
        ];
        assert_eq!(s.events(), expected.as_slice());
        assert_eq!(s.last_frame(), Some(13));
    }

    #[test]
    fn a_bad_line_is_refused_with_its_line_number() {
        let cases = [
            (
                "frame 1 key w\nframe x key w\n",
                "s.txt:2: frame number \"x\"",
            ),
            ("frame 1 key f13\n", "s.txt:1: unknown key \"f13\""),
            ("frame 1 key w sideways\n", "s.txt:1: key w"),
            ("frame 1 drag 1 nan\n", "s.txt:1: drag y \"nan\""),
            ("frame 1 screenshot a.jpg\n", "s.txt:1: screenshot a.jpg"),
            ("frame 1 resize 0 10\n", "s.txt:1: resize"),
            (
                "frame 0 screenshot a.png\n",
                "s.txt:1: screenshot at frame 0",
            ),
            ("\n\nframe 1 jump\n", "s.txt:3: unknown event \"jump\""),
            ("key w\n", "s.txt:1: expected `frame N EVENT`"),
        ];
        for (text, start) in cases {
            let e = parse(text).unwrap_err().to_string();
            assert!(e.starts_with(start), "{text:?} gave {e:?}");
        }
    }

    #[test]
    fn held_keys_stay_down_until_released_and_taps_last_one_frame() {
        let s = parse("frame 0 key w down\nframe 1 key 3\nframe 2 key w up\n").unwrap();
        let mut p = Player::new(s);
        let frames: Vec<FrameInput> = (0..3)
            .map(|shown| {
                let mut input = FrameInput::default();
                p.feed(shown, &mut input);
                input
            })
            .collect();
        assert_eq!(frames[0].pressed, [Key::W]);
        assert_eq!(frames[0].held, [Key::W]);
        assert_eq!(frames[1].pressed, [Key::Key3]);
        assert!(frames[1].held.contains(&Key::W) && frames[1].held.contains(&Key::Key3));
        assert!(frames[2].held.is_empty() && frames[2].pressed.is_empty());
    }
}
