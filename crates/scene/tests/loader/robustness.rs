//! No input makes the loader panic: systematic corruptions of a valid scene
//! (every truncation, every line deleted, every number replaced by hostile
//! values) either load or come back as a `SceneError` with a line.

use crate::support::parse;

const SCENE: &str = include_str!(concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../scenes/shadow-plane.toml"
));

fn check(text: &str) {
    if let Err(e) = parse(text) {
        assert!(!e.message.is_empty());
        assert!(e.line >= 1 && e.line <= text.lines().count().max(1), "{e}");
    }
}

#[test]
fn every_truncation_is_handled() {
    for (i, _) in SCENE.char_indices() {
        check(&SCENE[..i]);
    }
}

#[test]
fn every_deleted_line_is_handled() {
    let lines: Vec<&str> = SCENE.lines().collect();
    for i in 0..lines.len() {
        let mut l = lines.clone();
        l.remove(i);
        check(&l.join("\n"));
    }
}

#[test]
fn every_number_replaced_by_a_hostile_value_is_handled() {
    let hostile = [
        "nan",
        "-inf",
        "inf",
        "0",
        "-1",
        "1e39",
        "1e300",
        "-0.0",
        "\"x\"",
        "[]",
        "[1,2]",
        "true",
        "9223372036854775807",
        "{a = 1}",
        "1979-05-27",
    ];
    let bytes = SCENE.as_bytes();
    let mut i = 0;
    let mut replaced = 0;
    while i < bytes.len() {
        let c = bytes[i];
        let starts =
            (c.is_ascii_digit() || c == b'-') && (i == 0 || !bytes[i - 1].is_ascii_alphanumeric());
        if starts && !SCENE[..i].ends_with('#') {
            let mut j = i + 1;
            while j < bytes.len()
                && (bytes[j].is_ascii_digit() || bytes[j] == b'.' || bytes[j] == b'e')
            {
                j += 1;
            }
            for h in hostile {
                check(&format!("{}{}{}", &SCENE[..i], h, &SCENE[j..]));
            }
            replaced += 1;
            i = j;
        } else {
            i += 1;
        }
    }
    assert!(replaced > 50, "only {replaced} numbers found");
}

#[test]
fn arbitrary_bytes_are_handled() {
    // A cheap deterministic generator: no external randomness, same run every time.
    let mut x: u64 = 0x9e37_79b9_7f4a_7c15;
    let alphabet = b"[]{}=\"'.,-+0123456789 \n#abcdefnaitruxyz_";
    for _ in 0..2000 {
        let mut s = String::new();
        for _ in 0..(x % 200) {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            s.push(alphabet[(x % alphabet.len() as u64) as usize] as char);
        }
        check(&format!("{}{s}", &SCENE[..(x as usize) % SCENE.len()]));
    }
}
