//! Robot names drawn in world units: Rerun 0.36 draws a label at a fixed screen
//! size, so with the whole world in view a label is several times larger than its robot and
//! ten labels cover the robots. A name drawn as line strips in world units is smaller than
//! its robot at every zoom: a faint mark beside each disc with the whole world in view,
//! readable once the view is zoomed in on a few robots.
//!
//! The font is a seven-segment style stroke font for `p` and the digits, the characters of a
//! robot's name (`p12`); any other character is a blank.

/// A name's height, from the top of its digits to their baseline, in robot radii.
pub const NAME_HEIGHT_RADII: f32 = 1.0;

/// Where a name starts: this many radii right of the robot's centre (just outside its disc).
pub const NAME_OFFSET_RADII: f32 = 1.25;

/// A glyph's width, and the advance from one glyph to the next, as fractions of its height.
const GLYPH_WIDTH: f32 = 0.5;
const ADVANCE: f32 = 0.75;

/// The strokes of a character on a 1 × 2 grid: x to the right, y downwards (the 2D view's
/// convention), the top of a digit at y = 0 and the baseline at y = 2.
fn glyph(c: char) -> &'static [&'static [(f32, f32)]] {
    const TL: (f32, f32) = (0.0, 0.0);
    const TR: (f32, f32) = (1.0, 0.0);
    const ML: (f32, f32) = (0.0, 1.0);
    const MR: (f32, f32) = (1.0, 1.0);
    const BL: (f32, f32) = (0.0, 2.0);
    const BR: (f32, f32) = (1.0, 2.0);
    match c {
        '0' => &[&[TL, TR, BR, BL, TL]],
        '1' => &[&[(0.2, 0.4), (0.6, 0.0), (0.6, 2.0)]],
        '2' => &[&[TL, TR, MR, ML, BL, BR]],
        '3' => &[&[TL, TR, BR, BL], &[ML, MR]],
        '4' => &[&[TL, ML, MR], &[TR, BR]],
        '5' => &[&[TR, TL, ML, MR, BR, BL]],
        '6' => &[&[TR, TL, BL, BR, MR, ML]],
        '7' => &[&[TL, TR, (0.4, 2.0)]],
        '8' => &[&[TL, TR, BR, BL, TL], &[ML, MR]],
        '9' => &[&[MR, ML, TL, TR, BR, BL]],
        // Lower case, with a descender below the baseline.
        'p' => &[&[(0.0, 0.8), (0.0, 2.6)], &[(0.0, 0.8), (1.0, 0.8), BR, BL]],
        _ => &[],
    }
}

/// The strokes of `text` with its top left corner at the origin, `height` tall (the digits'
/// height; a `p`'s descender reaches 1.3 × `height`).
pub fn strokes(text: &str, height: f32) -> Vec<Vec<[f32; 2]>> {
    let unit = height / 2.0;
    let mut out = Vec::new();
    for (k, c) in text.chars().enumerate() {
        let left = k as f32 * ADVANCE * height;
        for stroke in glyph(c) {
            out.push(
                stroke
                    .iter()
                    .map(|&(x, y)| [left + x * GLYPH_WIDTH * height, y * unit])
                    .collect(),
            );
        }
    }
    out
}

/// The strokes of a robot's name relative to its centre: `NAME_HEIGHT_RADII` radii tall,
/// starting `NAME_OFFSET_RADII` radii to the right, vertically centred on the disc.
pub fn robot_name(text: &str, radius: f32) -> Vec<Vec<[f32; 2]>> {
    let height = NAME_HEIGHT_RADII * radius;
    let (dx, dy) = (NAME_OFFSET_RADII * radius, -height / 2.0);
    let mut s = strokes(text, height);
    for p in s.iter_mut().flatten() {
        p[0] += dx;
        p[1] += dy;
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bounds(s: &[Vec<[f32; 2]>]) -> [f32; 4] {
        let pts = s.iter().flatten();
        let mut b = [
            f32::INFINITY,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NEG_INFINITY,
        ];
        for p in pts {
            b = [
                b[0].min(p[0]),
                b[1].min(p[1]),
                b[2].max(p[0]),
                b[3].max(p[1]),
            ];
        }
        b
    }

    #[test]
    fn a_name_is_smaller_than_its_robot_and_beside_it() {
        let r = 5.0;
        let s = robot_name("p12", r);
        // p, 1 and 2: two strokes, one, one.
        assert_eq!(s.len(), 4);
        let [x0, y0, x1, y1] = bounds(&s);
        // Outside the disc, to its right.
        assert!(x0 >= r, "{x0}");
        // Shorter than the disc's diameter, the descender included.
        assert!(y1 - y0 < 2.0 * r, "{}", y1 - y0);
        // Digits from -r/2 to r/2 around the centre line.
        assert!((y0 + r / 2.0).abs() < 1e-6);
        // Three glyphs: two advances and a glyph width.
        assert!((x1 - x0 - (2.0 * ADVANCE + GLYPH_WIDTH) * r).abs() < 1e-5);
    }

    #[test]
    fn every_character_of_a_name_has_strokes() {
        for c in "p0123456789".chars() {
            assert!(!glyph(c).is_empty(), "{c}");
            for stroke in glyph(c) {
                assert!(stroke.len() >= 2);
                assert!(stroke
                    .iter()
                    .all(|&(x, y)| (0.0..=1.0).contains(&x) && (0.0..=2.6).contains(&y)));
            }
        }
        assert!(strokes("x", 1.0).is_empty());
    }
}
