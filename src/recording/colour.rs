//! The colours of a recording: robots' hues spaced by the golden angle, a protocol layer's
//! colour from its name, and grey for crashed robots. Every colour is a function of an id or
//! a name, never of the run's order or of a hash map's, so the same run draws the same
//! picture.

use nekosim_actors::world::geometry::normalize_deg;

/// An RGB colour.
pub type Rgb = [u8; 3];

/// Colour of crashed robots.
pub const GREY: Rgb = [128, 128, 128];

/// The colour a Look-Compute-Move light `l` is drawn in: the colours spin-light names in its
/// order (black, white, red, yellow, green), then hues spaced by the golden angle. While a
/// new light is being written (`pending`), the robot shows the mean of the old and the new.
pub fn light_colour(l: u8, pending: Option<u8>) -> Rgb {
    let one = |l: u8| -> Rgb {
        match l {
            0 => [40, 40, 40],
            1 => [240, 240, 240],
            2 => [220, 40, 40],
            3 => [240, 210, 40],
            4 => [40, 180, 70],
            k => hsv(f64::from(k) * 137.507_764, 0.8, 0.9),
        }
    };
    let (a, b) = (one(l), one(pending.unwrap_or(l)));
    [0, 1, 2].map(|i| ((u16::from(a[i]) + u16::from(b[i])) / 2) as u8)
}

/// A distinct colour for robot `i` (hues spaced by the golden angle).
pub fn robot_colour(i: u32) -> Rgb {
    hsv(f64::from(i) * 137.507_764, 0.75, 0.9)
}

/// The colour of a protocol layer, from its name (FNV-1a, so it does not depend on the run).
pub fn layer_colour(layer: &str) -> Rgb {
    let mut h: u32 = 0x811c_9dc5;
    for b in layer.bytes() {
        h ^= u32::from(b);
        h = h.wrapping_mul(0x0100_0193);
    }
    hsv(f64::from(h % 360), 0.9, 1.0)
}

fn hsv(hue: f64, s: f64, v: f64) -> Rgb {
    let h = normalize_deg(hue) / 60.0;
    let c = v * s;
    let x = c * (1.0 - (h % 2.0 - 1.0).abs());
    let (r, g, b) = match h as u32 {
        0 => (c, x, 0.0),
        1 => (x, c, 0.0),
        2 => (0.0, c, x),
        3 => (0.0, x, c),
        4 => (x, 0.0, c),
        _ => (c, 0.0, x),
    };
    let m = v - c;
    let q = |u: f64| ((u + m) * 255.0).round() as u8;
    [q(r), q(g), q(b)]
}
