//! What the monitor shows: code value -> luminance through the display's
//! EOTF, each camera frame held from refresh to refresh, and the visual
//! angle an ROI subtends at the driver's eye.

use ledflicker_plan::plan::display::{Display, Eotf};

/// BT.1886's exponent (ITU-R BT.1886 Annex 1), and the 2.4 power of
/// IEC 61966-2-1's sRGB curve above its linear toe.
const GAMMA: f64 = 2.4;

/// Luminance, cd/m^2, of code value `v` (clamped to 0..1: the monitor
/// cannot show more than full scale).
pub fn luminance_cd_m2(d: &Display, v: f64) -> f64 {
    let v = v.clamp(0.0, 1.0);
    match d.eotf {
        Eotf::Srgb => {
            // IEC 61966-2-1:1999 section 5.2, decoding.
            let linear = if v <= 0.04045 {
                v / 12.92
            } else {
                ((v + 0.055) / 1.055).powf(GAMMA)
            };
            d.black_cd_m2 + (d.peak_cd_m2 - d.black_cd_m2) * linear
        }
        Eotf::Bt1886 => {
            // ITU-R BT.1886 Annex 1: L = a max(V + b, 0)^gamma with
            // a = (Lw^(1/g) - Lb^(1/g))^g, b = Lb^(1/g) / (Lw^(1/g) - Lb^(1/g)).
            let (w, b) = (
                d.peak_cd_m2.powf(1.0 / GAMMA),
                d.black_cd_m2.powf(1.0 / GAMMA),
            );
            let a = (w - b).powf(GAMMA);
            a * (v + b / (w - b)).max(0.0).powf(GAMMA)
        }
    }
}

/// One stretch of constant luminance on the screen.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hold {
    /// Start, seconds from the first refresh that shows the segment.
    pub start_s: f64,
    /// End, seconds (> start).
    pub end_s: f64,
    /// Luminance, cd/m^2.
    pub luminance_cd_m2: f64,
}

/// The screen's luminance over the frames at `times_s` (starts, seconds,
/// increasing) with luminances `luminance_cd_m2`, the last frame held for
/// `frame_s`: frame `k` appears at the first refresh at or after its
/// start and stays until the next frame appears. A frame superseded
/// before any refresh is never shown, as on a real sample-and-hold panel.
/// The sample-and-hold delay (one frame of readout, the link) shifts
/// every frame alike and so is left out.
pub fn holds(refresh_hz: f64, times_s: &[f64], luminance_cd_m2: &[f64], frame_s: f64) -> Vec<Hold> {
    // A tolerance of a millionth of a refresh keeps a frame exactly on a
    // refresh (the simulator's n / fps at 30 fps on 60 Hz) on it.
    let tick = |t: f64| (t * refresh_hz - 1e-6).ceil() / refresh_hz;
    let regular = on_a_clock(times_s, refresh_hz);
    // On the clock, the last frame lasts the clock's interval too.
    let frame_s = regular.as_ref().map_or(frame_s, |(_, d)| *d);
    let times_s = regular.as_ref().map_or(times_s, |(t, _)| t.as_slice());
    let Some(&t0) = times_s.first() else {
        return Vec::new();
    };
    let origin = tick(t0);
    let mut out: Vec<Hold> = Vec::with_capacity(times_s.len());
    for (k, (&t, &l)) in times_s.iter().zip(luminance_cd_m2).enumerate() {
        let next = times_s.get(k + 1).copied().unwrap_or(t + frame_s);
        let (a, b) = (tick(t) - origin, tick(next) - origin);
        if b > a {
            out.push(Hold {
                start_s: a,
                end_s: b,
                luminance_cd_m2: l,
            });
        }
    }
    out
}

/// Radius, degrees, of the disk with the visual area of an ROI of
/// `width_px` x `height_px` of an image `image_width_px` wide shown
/// `d.image_width_mm` wide at `d.distance_mm` from the eye.
pub fn roi_radius_deg(d: &Display, width_px: u32, height_px: u32) -> f64 {
    let mm_per_px = d.image_width_mm / f64::from(d.image_width_px.max(1));
    let angle = |px: u32| {
        let size_mm = f64::from(px) * mm_per_px;
        2.0 * (size_mm / (2.0 * d.distance_mm)).atan().to_degrees()
    };
    (angle(width_px) * angle(height_px) / std::f64::consts::PI).sqrt()
}

/// Frame times rounded to a coarse time base (a video's milliseconds) put
/// on the camera's frame clock `a + k d`. Rounded times would move frames
/// across refreshes: at 60 fps on 60 Hz, one frame in three would never
/// be shown. The clock is fitted to the times by least squares (twice: the
/// second time without the frames more than the tolerance off); its
/// interval is taken as exactly `p / (q R)` when `d R` is within 1e-4 of
/// such a ratio (`q` up to 12: a camera locked to the monitor's rate, 60
/// fps on 60 Hz, 25 on 60), since a fit to rounded times is off by a
/// little that adds up over a segment. Each frame within `min(1 ms, d / 8)`
/// of the clock takes its time; a frame further off (really late or
/// early) keeps its own. Returns the times and the clock's interval (the
/// last frame's hold); `None` when no time moves by more than 1 ns
/// (exact times stay as they are).
fn on_a_clock(times_s: &[f64], refresh_hz: f64) -> Option<(Vec<f64>, f64)> {
    let n = times_s.len();
    if n < 3 {
        return None;
    }
    let span = times_s[n - 1] - times_s[0];
    let d0 = span / (n - 1) as f64;
    if d0 <= 0.0 {
        return None;
    }
    let tolerance = (d0 / 8.0).min(1e-3);
    // Least squares of `t_k = a + k d` over the frames `use_k` keeps.
    let fit = |keep: &dyn Fn(usize) -> bool| -> Option<(f64, f64)> {
        let pts: Vec<(f64, f64)> = (0..n)
            .filter(|&k| keep(k))
            .map(|k| (k as f64, times_s[k]))
            .collect();
        let m = pts.len() as f64;
        if m < 2.0 {
            return None;
        }
        let (sx, sy) = pts.iter().fold((0.0, 0.0), |(a, b), p| (a + p.0, b + p.1));
        let (mx, my) = (sx / m, sy / m);
        let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
        let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
        (sxx > 0.0).then(|| (my - sxy / sxx * mx, sxy / sxx))
    };
    let (a, d) = fit(&|_| true)?;
    let inlier = |k: usize| (times_s[k] - (a + k as f64 * d)).abs() <= tolerance;
    let (_, mut d) = fit(&inlier)?;
    let ratio = d * refresh_hz;
    if let Some(exact) = (1..=12).find_map(|q| {
        let p = (ratio * q as f64).round();
        (p >= 1.0 && (ratio - p / q as f64).abs() <= 1e-4 * ratio)
            .then(|| p / (q as f64 * refresh_hz))
    }) {
        d = exact;
    }
    // The clock's phase with that interval: the inliers' mean offset.
    let offsets: Vec<f64> = (0..n)
        .filter(|&k| inlier(k))
        .map(|k| times_s[k] - k as f64 * d)
        .collect();
    if offsets.is_empty() {
        return None;
    }
    let a = offsets.iter().sum::<f64>() / offsets.len() as f64;
    let snapped: Vec<f64> = (0..n)
        .map(|k| {
            let clock = a + k as f64 * d;
            if (times_s[k] - clock).abs() <= tolerance {
                clock
            } else {
                times_s[k]
            }
        })
        .collect();
    let moved = snapped
        .iter()
        .zip(times_s)
        .any(|(s, t)| (s - t).abs() > 1e-9);
    moved.then_some((snapped, d))
}

#[cfg(test)]
mod tests {
    use super::*;
    use ledflicker_plan::plan::display::DisplayPreset;

    fn display(eotf: Eotf) -> Display {
        Display {
            preset: DisplayPreset::Night,
            eotf,
            refresh_hz: 60.0,
            peak_cd_m2: 50.0,
            black_cd_m2: 0.05,
            image_width_mm: 155.0,
            distance_mm: 700.0,
            full_scale_dn: 255.0,
            image_width_px: 1920,
        }
    }

    #[test]
    fn both_eotfs_span_black_to_peak_and_rise() {
        for eotf in [Eotf::Srgb, Eotf::Bt1886] {
            let d = display(eotf);
            assert!((luminance_cd_m2(&d, 0.0) - 0.05).abs() < 1e-9, "{eotf:?}");
            assert!((luminance_cd_m2(&d, 1.0) - 50.0).abs() < 1e-9, "{eotf:?}");
            assert!((luminance_cd_m2(&d, 2.0) - 50.0).abs() < 1e-9, "{eotf:?}");
            let mut last = 0.0;
            for i in 0..=1000 {
                let l = luminance_cd_m2(&d, i as f64 / 1000.0);
                assert!(l >= last, "{eotf:?} at {i}");
                last = l;
            }
        }
    }

    #[test]
    fn srgb_is_continuous_at_its_toe_and_half_is_a_fifth() {
        let d = Display {
            black_cd_m2: 0.0,
            ..display(Eotf::Srgb)
        };
        let below = luminance_cd_m2(&d, 0.04045);
        let above = luminance_cd_m2(&d, 0.04045 + 1e-12);
        assert!((above - below).abs() < 1e-6);
        // sRGB 0.5 decodes to 0.2140 of white (IEC 61966-2-1).
        assert!((luminance_cd_m2(&d, 0.5) / 50.0 - 0.214_041).abs() < 1e-6);
    }

    #[test]
    fn frames_on_the_refresh_grid_hold_for_one_frame() {
        let times: Vec<f64> = (0..4).map(|n| n as f64 / 30.0).collect();
        let h = holds(60.0, &times, &[1.0, 2.0, 3.0, 4.0], 1.0 / 30.0);
        assert_eq!(h.len(), 4);
        for (k, x) in h.iter().enumerate() {
            assert!((x.start_s - k as f64 / 30.0).abs() < 1e-12);
            assert!((x.end_s - x.start_s - 1.0 / 30.0).abs() < 1e-12);
        }
    }

    #[test]
    fn a_25_fps_camera_on_a_60_hz_monitor_judders_three_two() {
        // 25 fps on 60 Hz: frames last 3 or 2 refreshes (mean 2.4).
        let times: Vec<f64> = (0..10).map(|n| n as f64 / 25.0).collect();
        let h = holds(60.0, &times, &[1.0; 10], 1.0 / 25.0);
        let refreshes: Vec<i64> = h
            .iter()
            .map(|x| ((x.end_s - x.start_s) * 60.0).round() as i64)
            .collect();
        assert!(refreshes.iter().all(|&r| r == 2 || r == 3), "{refreshes:?}");
        assert_eq!(refreshes.iter().sum::<i64>(), 24);
    }

    #[test]
    fn times_rounded_to_milliseconds_are_shown_on_the_frame_clock() {
        // A 60 fps video whose times are rounded to 1 ms (16, 33, 50 ...
        // ms): read literally, one frame in three falls before its refresh
        // and the next replaces it unseen.
        let times: Vec<f64> = (0..61)
            .map(|n| (n as f64 * 1000.0 / 60.0).round() / 1000.0)
            .collect();
        let h = holds(60.0, &times, &[1.0; 61], 1.0 / 60.0);
        assert_eq!(h.len(), 61);
        assert!(
            h.iter()
                .all(|x| ((x.end_s - x.start_s) * 60.0 - 1.0).abs() < 1e-9)
        );
        // One frame really late keeps its time; the others stay on the
        // clock, each shown for one refresh but the late one's neighbours.
        let mut late = times.clone();
        late[10] += 0.0012;
        let (snapped, _) = on_a_clock(&late, 60.0).unwrap();
        assert!((snapped[10] - late[10]).abs() < 1e-12);
        assert!((snapped[30] - 30.0 / 60.0 - (snapped[0] - 0.0)).abs() < 1e-9);
        let h = holds(60.0, &late, &[1.0; 61], 1.0 / 60.0);
        assert_eq!(h.len(), 60, "only the late frame is lost");
        // Rounded times whose first and last round in opposite directions
        // (a segment starting at frame 31 of a 60 fps video): every frame
        // is still shown once.
        for first in [31, 32] {
            let shifted: Vec<f64> = (first..first + 240)
                .map(|n| (n as f64 * 1000.0 / 60.0).round() / 1000.0)
                .collect();
            let h = holds(60.0, &shifted, &[1.0; 240], 0.016_666_712_963_766_733);
            assert_eq!(h.len(), 240, "from frame {first}");
            assert!(
                h.iter()
                    .all(|x| ((x.end_s - x.start_s) * 60.0 - 1.0).abs() < 1e-9),
                "from frame {first}: the last frame too holds one refresh"
            );
        }
        let shifted: Vec<f64> = (31..31 + 240)
            .map(|n| (n as f64 * 1000.0 / 60.0).round() / 1000.0)
            .collect();
        let h = holds(60.0, &shifted, &[1.0; 240], 1.0 / 60.0);
        assert_eq!(h.len(), 240);
        assert!(
            h.iter()
                .all(|x| ((x.end_s - x.start_s) * 60.0 - 1.0).abs() < 1e-9)
        );
        // Exact times are left as they are.
        let exact: Vec<f64> = (0..61).map(|n| n as f64 / 25.0).collect();
        assert_eq!(on_a_clock(&exact, 60.0), None);
    }

    #[test]
    fn frames_faster_than_the_refresh_are_dropped() {
        let times: Vec<f64> = (0..12).map(|n| n as f64 / 120.0).collect();
        let h = holds(60.0, &times, &[1.0; 12], 1.0 / 120.0);
        assert_eq!(h.len(), 6);
    }

    #[test]
    fn roi_angle_follows_the_screen_geometry() {
        // 192 px of a 1920 px image 155 mm wide: 15.5 mm at 700 mm.
        let d = display(Eotf::Srgb);
        let w = 2.0 * (15.5f64 / 1400.0).atan().to_degrees();
        let r = roi_radius_deg(&d, 192, 192);
        assert!((r - (w * w / std::f64::consts::PI).sqrt()).abs() < 1e-12);
        assert!((w - 1.2686).abs() < 1e-3, "{w}");
    }
}
