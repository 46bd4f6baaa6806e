//! Statistics of a sweep point's replications: mean, sample standard deviation and the 95 %
//! confidence interval of the mean (Student's t with n - 1 degrees of freedom).

use statrs::distribution::{Continuous, ContinuousCDF, StudentsT};

/// A metric's statistics over the runs of one point that have a value of it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stats {
    pub n: usize,
    pub mean: f64,
    /// Sample standard deviation (n - 1); `None` for fewer than two values.
    pub sd: Option<f64>,
    /// The 95 % confidence interval of the mean; `None` for fewer than two values.
    pub ci95: Option<(f64, f64)>,
}

/// The statistics of `values` (in the order given, so that the sums are the same whoever
/// computes them); `None` when there are none.
pub fn stats(values: &[f64]) -> Option<Stats> {
    let n = values.len();
    if n == 0 {
        return None;
    }
    let mean = values.iter().sum::<f64>() / n as f64;
    if n < 2 {
        return Some(Stats {
            n,
            mean,
            sd: None,
            ci95: None,
        });
    }
    let var = values.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / (n - 1) as f64;
    let sd = var.sqrt();
    let t = StudentsT::new(0.0, 1.0, (n - 1) as f64)
        .map(|d| {
            // statrs' inverse is good to about 1e-9; Newton steps on its accurate cdf and
            // density make the quantile exact to rounding.
            let mut t = d.inverse_cdf(0.975);
            for _ in 0..3 {
                t -= (d.cdf(t) - 0.975) / d.pdf(t);
            }
            t
        })
        .unwrap_or(f64::NAN);
    let half = t * sd / (n as f64).sqrt();
    Some(Stats {
        n,
        mean,
        sd: Some(sd),
        ci95: Some((mean - half, mean + half)),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_a_textbook_example() {
        // 1..=5: mean 3, s = sqrt(2.5), t(0.975, 4) = 2.776445105...
        let s = stats(&[1.0, 2.0, 3.0, 4.0, 5.0]).unwrap();
        assert_eq!(s.mean, 3.0);
        assert!((s.sd.unwrap() - 2.5f64.sqrt()).abs() < 1e-12);
        let half = 2.776_445_105_197_799 * 2.5f64.sqrt() / 5f64.sqrt();
        let (lo, hi) = s.ci95.unwrap();
        assert!((lo - (3.0 - half)).abs() < 1e-12 && (hi - (3.0 + half)).abs() < 1e-12);
        // Two values: t(0.975, 1) = tan(0.475 pi) = 12.706204736174...
        let (lo, _) = stats(&[0.0, 2.0]).unwrap().ci95.unwrap();
        let t1 = (0.475 * std::f64::consts::PI).tan();
        assert!((lo - (1.0 - t1)).abs() < 1e-12, "{lo}");
        // Three values: t(0.975, 2) = 0.95 / sqrt(2 * 0.975 * 0.025) exactly.
        let t2 = 0.95 / (2.0f64 * 0.975 * 0.025).sqrt();
        let s3 = stats(&[1.0, 2.0, 4.0]).unwrap();
        let half = t2 * s3.sd.unwrap() / 3f64.sqrt();
        assert!((s3.ci95.unwrap().0 - (s3.mean - half)).abs() < 1e-12);
        assert_eq!(stats(&[7.0]).unwrap().sd, None);
        assert_eq!(stats(&[]), None);
    }
}
