//! How the Neko log writes numbers, points and what a robot touched (seed fig. 4.12): three
//! decimals, `[x,y]`, `pK`. The log and the sensors' readings in it (the built-in sensors'
//! texts) write them alike.

use super::geometry::Point;
use super::Obstacle;

/// Three decimals, as `format!("{v:.3}")` writes them, with no negative zero.
///
/// The log writes hundreds of thousands of these, so finite values up to 2^60 are rounded in
/// integers: `v = m 2^e` exactly, and `1000 m 2^e` is rounded to the nearest integer, ties to
/// even, which is what the standard formatter does with the exact value. The unit test checks
/// it against `format!` on random values and on every kind of tie.
pub fn num(v: f64) -> String {
    match thousandths(v) {
        Some(0) => "0.000".into(),
        Some(k) => {
            let sign = if v < 0.0 { "-" } else { "" };
            format!("{sign}{}.{:03}", k / 1000, k % 1000)
        }
        None => {
            let s = format!("{v:.3}");
            if s == "-0.000" {
                "0.000".into()
            } else {
                s
            }
        }
    }
}

/// `|v|` in thousandths, rounded to nearest with ties to even; `None` when not finite or
/// beyond 2^60.
fn thousandths(v: f64) -> Option<u128> {
    if !v.is_finite() {
        return None;
    }
    let bits = v.to_bits();
    let exp = ((bits >> 52) & 0x7ff) as i32;
    let frac = u128::from(bits & ((1 << 52) - 1));
    let (m, e) = if exp == 0 {
        (frac, -1074)
    } else {
        (frac | 1 << 52, exp - 1075)
    };
    let n = m * 1000;
    if e >= 0 {
        return (e <= 7).then(|| n << e);
    }
    let s = e.unsigned_abs();
    if s >= 127 {
        // Below 2^-63: rounds to zero.
        return Some(0);
    }
    let q = n >> s;
    let r = n - (q << s);
    let half = 1u128 << (s - 1);
    Some(if r > half || (r == half && q & 1 == 1) {
        q + 1
    } else {
        q
    })
}

/// A point as the Neko log writes it: `[x,y]`, three decimals.
pub fn point_text(p: Point) -> String {
    format!("[{},{}]", num(p.x), num(p.y))
}

/// What a robot touched, as the Neko log writes it: `pK`, `boundary` or `obstacle:K`.
pub fn obstacle_text(o: Obstacle) -> String {
    o.to_string()
}
