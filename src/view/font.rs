//! A 5x7 bitmap font for the overlay, drawn by hand for this project: each
//! glyph is seven rows of five cells, `#` lit and `.` dark, so the shapes can
//! be read (and corrected) in the source. Lower-case letters are drawn as
//! capitals; characters without a glyph are drawn as `?`.

/// Glyph cell size, and the advance from one character to the next.
pub const GLYPH_W: usize = 5;
pub const GLYPH_H: usize = 7;
pub const ADVANCE_X: usize = GLYPH_W + 1;
pub const ADVANCE_Y: usize = GLYPH_H + 2;

#[rustfmt::skip]
const GLYPHS: &[(char, [&str; GLYPH_H])] = &[
    (' ', [".....", ".....", ".....", ".....", ".....", ".....", "....."]),
    ('0', [".###.", "#...#", "#..##", "#.#.#", "##..#", "#...#", ".###."]),
    ('1', ["..#..", ".##..", "..#..", "..#..", "..#..", "..#..", ".###."]),
    ('2', [".###.", "#...#", "....#", "...#.", "..#..", ".#...", "#####"]),
    ('3', ["####.", "....#", "....#", ".###.", "....#", "....#", "####."]),
    ('4', ["...#.", "..##.", ".#.#.", "#..#.", "#####", "...#.", "...#."]),
    ('5', ["#####", "#....", "####.", "....#", "....#", "#...#", ".###."]),
    ('6', ["..##.", ".#...", "#....", "####.", "#...#", "#...#", ".###."]),
    ('7', ["#####", "....#", "...#.", "..#..", ".#...", ".#...", ".#..."]),
    ('8', [".###.", "#...#", "#...#", ".###.", "#...#", "#...#", ".###."]),
    ('9', [".###.", "#...#", "#...#", ".####", "....#", "...#.", ".##.."]),
    ('A', [".###.", "#...#", "#...#", "#####", "#...#", "#...#", "#...#"]),
    ('B', ["####.", "#...#", "#...#", "####.", "#...#", "#...#", "####."]),
    ('C', [".###.", "#...#", "#....", "#....", "#....", "#...#", ".###."]),
    ('D', ["###..", "#..#.", "#...#", "#...#", "#...#", "#..#.", "###.."]),
    ('E', ["#####", "#....", "#....", "####.", "#....", "#....", "#####"]),
    ('F', ["#####", "#....", "#....", "####.", "#....", "#....", "#...."]),
    ('G', [".###.", "#...#", "#....", "#.###", "#...#", "#...#", ".####"]),
    ('H', ["#...#", "#...#", "#...#", "#####", "#...#", "#...#", "#...#"]),
    ('I', [".###.", "..#..", "..#..", "..#..", "..#..", "..#..", ".###."]),
    ('J', ["..###", "...#.", "...#.", "...#.", "...#.", "#..#.", ".##.."]),
    ('K', ["#...#", "#..#.", "#.#..", "##...", "#.#..", "#..#.", "#...#"]),
    ('L', ["#....", "#....", "#....", "#....", "#....", "#....", "#####"]),
    ('M', ["#...#", "##.##", "#.#.#", "#.#.#", "#...#", "#...#", "#...#"]),
    ('N', ["#...#", "#...#", "##..#", "#.#.#", "#..##", "#...#", "#...#"]),
    ('O', [".###.", "#...#", "#...#", "#...#", "#...#", "#...#", ".###."]),
    ('P', ["####.", "#...#", "#...#", "####.", "#....", "#....", "#...."]),
    ('Q', [".###.", "#...#", "#...#", "#...#", "#.#.#", "#..#.", ".##.#"]),
    ('R', ["####.", "#...#", "#...#", "####.", "#.#..", "#..#.", "#...#"]),
    ('S', [".####", "#....", "#....", ".###.", "....#", "....#", "####."]),
    ('T', ["#####", "..#..", "..#..", "..#..", "..#..", "..#..", "..#.."]),
    ('U', ["#...#", "#...#", "#...#", "#...#", "#...#", "#...#", ".###."]),
    ('V', ["#...#", "#...#", "#...#", "#...#", "#...#", ".#.#.", "..#.."]),
    ('W', ["#...#", "#...#", "#...#", "#.#.#", "#.#.#", "#.#.#", ".#.#."]),
    ('X', ["#...#", "#...#", ".#.#.", "..#..", ".#.#.", "#...#", "#...#"]),
    ('Y', ["#...#", "#...#", ".#.#.", "..#..", "..#..", "..#..", "..#.."]),
    ('Z', ["#####", "....#", "...#.", "..#..", ".#...", "#....", "#####"]),
    ('.', [".....", ".....", ".....", ".....", ".....", ".##..", ".##.."]),
    (',', [".....", ".....", ".....", ".....", ".##..", "..#..", ".#..."]),
    (':', [".....", ".##..", ".##..", ".....", ".##..", ".##..", "....."]),
    ('/', ["....#", "....#", "...#.", "..#..", ".#...", "#....", "#...."]),
    ('-', [".....", ".....", ".....", ".###.", ".....", ".....", "....."]),
    ('+', [".....", "..#..", "..#..", "#####", "..#..", "..#..", "....."]),
    ('=', [".....", ".....", "#####", ".....", "#####", ".....", "....."]),
    ('%', ["##..#", "##..#", "...#.", "..#..", ".#...", "#..##", "#..##"]),
    ('(', ["...#.", "..#..", ".#...", ".#...", ".#...", "..#..", "...#."]),
    (')', [".#...", "..#..", "...#.", "...#.", "...#.", "..#..", ".#..."]),
    ('[', [".###.", ".#...", ".#...", ".#...", ".#...", ".#...", ".###."]),
    (']', [".###.", "...#.", "...#.", "...#.", "...#.", "...#.", ".###."]),
    ('_', [".....", ".....", ".....", ".....", ".....", ".....", "#####"]),
    ('\'', ["..#..", "..#..", ".....", ".....", ".....", ".....", "....."]),
    ('?', [".###.", "#...#", "....#", "...#.", "..#..", ".....", "..#.."]),
    ('!', ["..#..", "..#..", "..#..", "..#..", "..#..", ".....", "..#.."]),
    ('<', ["...#.", "..#..", ".#...", "#....", ".#...", "..#..", "...#."]),
    ('>', [".#...", "..#..", "...#.", "....#", "...#.", "..#..", ".#..."]),
    ('#', [".#.#.", ".#.#.", "#####", ".#.#.", "#####", ".#.#.", ".#.#."]),
];

/// The rows of `c`'s glyph as bit masks, bit 4 the leftmost cell.
pub fn glyph(c: char) -> [u8; GLYPH_H] {
    let c = c.to_ascii_uppercase();
    let rows = GLYPHS
        .iter()
        .find(|(g, _)| *g == c)
        .or_else(|| GLYPHS.iter().find(|(g, _)| *g == '?'))
        .map(|(_, rows)| rows)
        .expect("the font has a '?' glyph");
    let mut bits = [0u8; GLYPH_H];
    for (b, row) in bits.iter_mut().zip(rows) {
        *b = row
            .bytes()
            .fold(0, |acc, cell| (acc << 1) | (cell == b'#') as u8);
    }
    bits
}

/// Pixel width of `text` at `scale` (no trailing gap).
pub fn text_width(text: &str, scale: usize) -> usize {
    let n = text.chars().count();
    if n == 0 {
        0
    } else {
        (n * ADVANCE_X - 1) * scale
    }
}

/// A 0RGB pixel buffer to draw into; drawing clips at its edges.
pub struct Canvas<'a> {
    pub pixels: &'a mut [u32],
    pub width: usize,
    pub height: usize,
}

impl Canvas<'_> {
    /// Draws `text` with its top-left corner at (x, y), each font cell a
    /// `scale` x `scale` square of `color`.
    pub fn text(&mut self, x: usize, y: usize, scale: usize, color: u32, text: &str) {
        for (i, c) in text.chars().enumerate() {
            let gx = x + i * ADVANCE_X * scale;
            if gx >= self.width {
                break;
            }
            for (row, bits) in glyph(c).iter().enumerate() {
                for col in 0..GLYPH_W {
                    if bits & (1 << (GLYPH_W - 1 - col)) != 0 {
                        self.fill(gx + col * scale, y + row * scale, scale, scale, color);
                    }
                }
            }
        }
    }

    /// Fills a rectangle with `color`.
    pub fn fill(&mut self, x: usize, y: usize, w: usize, h: usize, color: u32) {
        self.each(x, y, w, h, |p| *p = color);
    }

    /// Darkens a rectangle to a quarter of its brightness, so light text
    /// stays legible over any image.
    pub fn shade(&mut self, x: usize, y: usize, w: usize, h: usize) {
        self.each(x, y, w, h, |p| *p = (*p >> 2) & 0x003f_3f3f);
    }

    fn each(&mut self, x: usize, y: usize, w: usize, h: usize, mut f: impl FnMut(&mut u32)) {
        let x1 = (x + w).min(self.width);
        let y1 = (y + h).min(self.height);
        for yy in y.min(y1)..y1 {
            let row = yy * self.width;
            for p in &mut self.pixels[row + x.min(x1)..row + x1] {
                f(p);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_glyph_is_seven_rows_of_five_cells() {
        for (c, rows) in GLYPHS {
            for row in rows {
                assert_eq!(row.len(), GLYPH_W, "{c:?}");
                assert!(row.bytes().all(|b| b == b'#' || b == b'.'), "{c:?}");
            }
        }
    }

    #[test]
    fn no_two_characters_share_a_glyph() {
        for (i, (a, ra)) in GLYPHS.iter().enumerate() {
            for (b, rb) in &GLYPHS[i + 1..] {
                assert_ne!(ra, rb, "{a:?} and {b:?} look the same");
                assert_ne!(a, b, "{a:?} is defined twice");
            }
        }
    }

    #[test]
    fn the_overlay_alphabet_is_covered() {
        let unknown = glyph('\u{2603}');
        for c in "0123456789ABCDEFGHIJKLMNOPQRSTUVWXYZ.,:/-+=%()[]_'!<>#".chars() {
            assert_ne!(glyph(c), unknown, "{c:?} falls back to '?'");
        }
        assert_eq!(glyph('x'), glyph('X'));
    }

    #[test]
    fn text_is_drawn_where_asked_and_clipped_at_the_edges() {
        let (w, h) = (20, 10);
        let mut pixels = vec![0u32; w * h];
        let mut canvas = Canvas {
            pixels: &mut pixels,
            width: w,
            height: h,
        };
        canvas.text(2, 1, 1, 0xffffff, "1");
        // '1' has its top cell in column 2 of the glyph.
        assert_eq!(pixels[w + 4], 0xffffff);
        assert_eq!(pixels[w + 2], 0);
        let lit = pixels.iter().filter(|&&p| p != 0).count();
        assert_eq!(lit, 10, "the cells of '1'");
        // Far past the right and bottom edges: nothing drawn, nothing panics.
        let mut canvas = Canvas {
            pixels: &mut pixels,
            width: w,
            height: h,
        };
        canvas.text(15, 8, 3, 0xff0000, "WWWWWW");
        canvas.text(500, 500, 2, 0xff0000, "W");
        assert!(
            pixels
                .iter()
                .all(|&p| p == 0 || p == 0xffffff || p == 0xff0000)
        );
        assert_eq!(text_width("ab", 2), 22);
    }
}
