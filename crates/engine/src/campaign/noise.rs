//! A ROI's frame-to-frame noise, from its trace: what `compare` takes as
//! the measurement uncertainty of the levels every KPI is computed from
//! (docs/campaigns.md, "The regression gate").
//!
//! In the steady ON and OFF segments the light does not change, so what
//! changes from one frame to the next is noise. The estimate, per
//! segment, uses successive differences, `sigma^2 = mean((x[i+1] - x[i])^2) / 2` over
//! pairs of consecutive frames of the same steady segment: a slow drift
//! (auto exposure settling, warm-up) barely enters it, unlike the spread
//! about the segment's mean.

use super::query::RoiData;

/// The noise of one ROI's trace, per steady segment: with shot noise a
/// bright frame is noisier than a dark one.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Noise {
    /// Standard deviation of one ON frame's ROI mean luma, DN (>= 0);
    /// `None` without two consecutive ON frames.
    pub on_dn: Option<f64>,
    /// The same of the OFF frames.
    pub off_dn: Option<f64>,
    /// OFF frames: the OFF reference is their mean.
    pub off_frames: usize,
}

/// The noise of each named column of a ledflicker trace CSV (header
/// `frame,time_s,segment,<roi>...`); `None` for a column the trace lacks.
pub fn of_trace(text: &str, rois: &[&str]) -> Vec<Option<Noise>> {
    let mut reader = csv::ReaderBuilder::new().from_reader(text.as_bytes());
    let Ok(header) = reader.headers().cloned() else {
        return vec![None; rois.len()];
    };
    let col = |name: &str| header.iter().position(|h| h == name);
    let segment = col("segment");
    let columns: Vec<Option<usize>> = rois.iter().map(|r| col(r)).collect();
    // Per ROI: (sum of squared steps, steps) of ON, then of OFF; OFF frames.
    let mut sums = vec![[(0.0f64, 0usize); 2]; rois.len()];
    let mut off_frames = 0;
    // The previous row's segment and values; only steady rows are parsed
    // (the PWM segment, most of a trace, is skipped unread).
    let mut previous: Option<(usize, Vec<Option<f64>>)> = None;
    let mut row = csv::ByteRecord::new();
    loop {
        match reader.read_byte_record(&mut row) {
            Ok(true) => {}
            Ok(false) => break,
            Err(_) => return vec![None; rois.len()],
        }
        let which = match segment.and_then(|s| row.get(s)) {
            Some(b"on") => 0,
            Some(b"off") => 1,
            _ => {
                previous = None;
                continue;
            }
        };
        let values: Vec<Option<f64>> = columns
            .iter()
            .map(|c| {
                c.and_then(|c| row.get(c))
                    .and_then(|v| std::str::from_utf8(v).ok())
                    .and_then(|v| v.parse::<f64>().ok())
                    .filter(|v| v.is_finite())
            })
            .collect();
        off_frames += usize::from(which == 1);
        if let Some((_, prev)) = previous.as_ref().filter(|(w, _)| *w == which) {
            for (k, (a, b)) in prev.iter().zip(&values).enumerate() {
                if let (Some(a), Some(b)) = (a, b) {
                    sums[k][which].0 += (b - a) * (b - a);
                    sums[k][which].1 += 1;
                }
            }
        }
        previous = Some((which, values));
    }
    let sigma = |(s, n): (f64, usize)| (n > 0).then(|| (s / n as f64 / 2.0).sqrt());
    sums.into_iter()
        .zip(&columns)
        .map(|([on, off], c)| {
            c.map(|_| Noise {
                on_dn: sigma(on),
                off_dn: sigma(off),
                off_frames,
            })
        })
        .collect()
}

/// Standard deviation of one run's KPI from its ROI's frame noise,
/// propagated to first order through the KPI's formula
/// (docs/campaigns.md, "Where sigma comes from"). The PWM extremes `min`
/// and `max` are single frames, each as noisy as a frame at its level; the
/// OFF reference is the mean of the OFF frames.
pub fn sigma_of(metric: &str, roi: &RoiData, value: Option<f64>) -> Option<f64> {
    let (min, max) = (roi.level_min, roi.level_max);
    let at_min = frame_noise(roi, min)?;
    let at_max = frame_noise(roi, max)?;
    let out = match metric {
        // PF = 100 (max - min) / (max + min)
        "percent_flicker" | "percent_flicker_worst_phase" => {
            let sum = max + min;
            (sum > 0.0).then(|| 200.0 * (max * at_min).hypot(min * at_max) / (sum * sum))
        }
        // FDI = (min - off) / off
        "fdi_2018" | "fdi_2018_worst_phase" => {
            let off = roi.level_off.filter(|off| *off > 0.0)?;
            let off_mean = roi.noise_off_dn? / (roi.off_frames.max(1) as f64).sqrt();
            Some((at_min / off).hypot(min * off_mean / (off * off)))
        }
        // A contrast of levels near `max`: its relative uncertainty is
        // about that of the difference of two frames.
        _ => value.map(|v| {
            v.abs() * std::f64::consts::SQRT_2 * at_max / max.abs().max(f64::MIN_POSITIVE)
        }),
    };
    out.filter(|v| v.is_finite())
}

/// Noise of one frame at luma `level`: shot noise makes the variance grow
/// linearly with the light, so it is interpolated (and extrapolated) in
/// variance between the OFF and the ON segment's, by level. With one
/// segment's noise only, that noise.
pub(super) fn frame_noise(roi: &RoiData, level: f64) -> Option<f64> {
    match (
        roi.noise_off_dn,
        roi.noise_on_dn,
        roi.level_off,
        roi.level_on,
    ) {
        (Some(s_off), Some(s_on), Some(off), Some(on)) if on != off => {
            let t = (level - off) / (on - off);
            Some(
                (s_off * s_off + (s_on * s_on - s_off * s_off) * t)
                    .max(0.0)
                    .sqrt(),
            )
        }
        (a, b, _, _) => a.or(b),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_steady_trace_without_noise_has_zero_noise_and_pwm_frames_do_not_count() {
        let csv = "frame,time_s,segment,led\n0,0,on,100\n1,0.1,on,100\n2,0.2,pwm,10\n3,0.3,pwm,200\n4,0.4,off,5\n5,0.5,off,5\n";
        let n = of_trace(csv, &["led", "missing"]);
        let want = Noise {
            on_dn: Some(0.0),
            off_dn: Some(0.0),
            off_frames: 2,
        };
        assert_eq!(n[0], Some(want));
        assert_eq!(n[1], None);
    }

    #[test]
    fn the_estimate_recovers_a_known_noise_and_ignores_a_slow_drift() {
        // x = level + drift + noise, the noise +s, +s, -s, -s, ... (standard
        // deviation s): successive differences are 0 or +-2s, mean square
        // 2 s^2 (the drift step adds 1e-6), so sigma = s.
        let s = 1.5;
        let mut csv = String::from("frame,time_s,segment,led\n");
        for i in 0..200 {
            let seg = if i < 100 { "on" } else { "off" };
            let level = if i < 100 { 180.0 } else { 20.0 };
            let x = level + 0.001 * i as f64 + if i % 4 < 2 { s } else { -s };
            csv.push_str(&format!("{i},{},{seg},{x}\n", i as f64 * 0.03));
        }
        let n = of_trace(&csv, &["led"])[0].unwrap();
        assert_eq!(n.off_frames, 100);
        // Each segment's 99 pairs hold 49 or 50 steps of 2s (the pair
        // across the ON -> OFF step is not counted): within 1 %.
        for sigma in [n.on_dn.unwrap(), n.off_dn.unwrap()] {
            assert!((sigma - s).abs() < 0.01 * s, "{sigma}");
        }
    }
}
