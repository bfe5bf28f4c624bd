//! The eye model against human flicker thresholds, not against itself:
//! de Lange (1958) and Kelly (1961), threshold modulation against
//! frequency at several luminances, as collected with elaTCSF
//! (tests/data/tcsf/SOURCE.md). docs/visibility.md states the errors the
//! test holds.

use super::tcsf::disk_sensitivity;

/// One measured threshold.
#[derive(Debug, Clone)]
pub struct Threshold {
    /// The study, e.g. `deLange1958`.
    pub data_set: String,
    /// Mean luminance of the field, cd/m^2.
    pub luminance_cd_m2: f64,
    /// Radius of the flickering disk, deg.
    pub radius_deg: f64,
    /// Frequency of the sinusoidal modulation, Hz.
    pub frequency_hz: f64,
    /// 1 / threshold modulation.
    pub sensitivity: f64,
}

/// Reads the data file (columns found by header name; rows that do not
/// parse are skipped).
pub fn read(text: &str) -> Vec<Threshold> {
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap_or("").split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name);
    let (l, r, d, f, s) = (
        col("luminance"),
        col("radius"),
        col("dataset"),
        col("t_frequency"),
        col("sensitivity"),
    );
    lines
        .filter(|x| !x.trim().is_empty())
        .filter_map(|line| {
            let v: Vec<&str> = line.split(',').collect();
            let num = |i: Option<usize>| i.and_then(|i| v.get(i)?.trim().parse::<f64>().ok());
            Some(Threshold {
                data_set: v.get(d?)?.to_string(),
                luminance_cd_m2: num(l)?,
                radius_deg: num(r)?,
                frequency_hz: num(f)?,
                sensitivity: num(s)?,
            })
        })
        .collect()
}

/// How the model meets one data set: log10(model / measured) per
/// threshold, summarised.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fit {
    /// Thresholds compared.
    pub count: usize,
    /// RMS of `log10(model / measured)`.
    pub rms: f64,
    /// Mean of `log10(model / measured)`: > 0 the model is more sensitive.
    pub bias: f64,
    /// RMS about the bias: the error of the curves' shape once the
    /// observers' overall sensitivity is matched.
    pub shape_rms: f64,
}

/// The fit of the model to the thresholds of `data_set`.
pub fn fit(data: &[Threshold], data_set: &str) -> Fit {
    let errs: Vec<f64> = data
        .iter()
        .filter(|t| t.data_set == data_set)
        .map(|t| {
            let m = disk_sensitivity(t.frequency_hz, t.radius_deg, t.luminance_cd_m2);
            m.log10() - t.sensitivity.log10()
        })
        .collect();
    let n = errs.len().max(1) as f64;
    let bias = errs.iter().sum::<f64>() / n;
    let ms = |c: f64| errs.iter().map(|e| (e - c) * (e - c)).sum::<f64>() / n;
    Fit {
        count: errs.len(),
        rms: ms(0.0).sqrt(),
        bias,
        shape_rms: ms(bias).sqrt(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn data() -> Vec<Threshold> {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../tests/data/tcsf/flicker_thresholds.csv"
        );
        let text = std::fs::read_to_string(path).expect("tests/data/tcsf/flicker_thresholds.csv");
        read(&text)
    }

    /// Sensitivities of the authors' reference implementation (elaTCSF.py
    /// of gfxdisp/elaTCSF, `sensitivity_disk` at eccentricity 0, run with
    /// SciPy's adaptive quadrature): (L cd/m^2, radius deg, f Hz, S).
    const REFERENCE: [(f64, f64, f64, f64); 6] = [
        (0.5, 0.2, 2.0, 40.231_067_295_650_88),
        (50.0, 1.27, 15.0, 158.235_929_279_549_28),
        (500.0, 0.5, 30.0, 42.030_207_105_191_92),
        (3.0, 20.0, 10.0, 409.340_771_053_033_8),
        (5000.0, 60.0, 60.0, 80.266_141_001_330_71),
        (0.05, 3.0, 5.0, 43.506_646_427_199_485),
    ];

    #[test]
    fn model_matches_the_authors_reference_code() {
        for (l, r, f, s) in REFERENCE {
            let got = disk_sensitivity(f, r, l);
            assert!(
                (got / s - 1.0).abs() < 1e-6,
                "L {l} r {r} f {f}: {got} vs {s}"
            );
        }
    }

    /// The bounds docs/visibility.md states, log10 units: (data set, RMS,
    /// shape RMS). The measured figures sit 0.01-0.03 below them.
    const STATED: [(&str, f64, f64); 3] = [
        ("deLange1958", 0.33, 0.14),
        ("kelly1961", 0.99, 0.28),
        ("deLange1958b", 0.41, 0.25),
    ];

    #[test]
    fn model_follows_de_lange_1958_and_kelly_1961_within_the_stated_error() {
        let d = data();
        for (set, rms, shape) in STATED {
            let f = fit(&d, set);
            assert!(f.count >= 7, "{set}: {} thresholds", f.count);
            assert!(f.rms <= rms, "{set}: {f:?}");
            assert!(f.shape_rms <= shape, "{set}: {f:?}");
            // The model errs towards seeing flicker: it is more sensitive
            // than these observers, never less on average.
            assert!(f.bias > 0.0, "{set}: {f:?}");
        }
    }

    #[test]
    fn the_data_file_has_every_luminance_of_both_studies() {
        // de Lange: 7 retinal illuminances, 2 deg field; Kelly: 5, 60 deg
        // field (radius 30 deg) with a blurred edge; de Lange's CFFs: 7.
        let d = data();
        let levels = |set: &str| {
            let mut l: Vec<f64> = d
                .iter()
                .filter(|t| t.data_set == set)
                .map(|t| t.luminance_cd_m2)
                .collect();
            l.sort_by(f64::total_cmp);
            l.dedup();
            l.len()
        };
        assert_eq!(levels("deLange1958"), 7);
        assert_eq!(levels("kelly1961"), 5);
        assert_eq!(levels("deLange1958b"), 7);
    }
}
