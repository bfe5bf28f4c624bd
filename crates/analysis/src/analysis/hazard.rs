//! Hazard class: what a driver may take the flicker in a camera-monitor
//! system (CMS) for, judged from its apparent frequency (Deegan 2018,
//! "Impact": drivers mistake flicker for turn signals or emergency vehicles).
//!
//! Ranges and their sources (cited in the report):
//! - traffic-signal-like, 0.8-1.0 Hz: flashing traffic signals flash 50 to
//!   60 times per minute (US MUTCD 2009, section 4D.30);
//! - turn-indicator-like, 1.0-2.0 Hz: direction indicators flash 90 +/- 30
//!   times per minute (UN Regulation No. 6 and No. 48, section 6.5.7);
//! - beacon-like, 1-4 Hz: warning lamps of emergency vehicles flash at 1 to
//!   4 Hz (SAE J845, 60 to 240 flashes per minute);
//! - peak annoyance, 10-25 Hz: the eye's temporal contrast sensitivity
//!   peaks near 15-20 Hz (de Lange 1958; Kelly 1961), and flashes in 15-20 Hz
//!   are the most provocative for photosensitive epilepsy (Harding and
//!   Jeavons 1994, cited by IEEE 1789-2015 section 4).
//!
//! A class applies only when the flicker is visible: see
//! [`VISIBLE_PERCENT_FLICKER`].

pub use ledflicker_results::analysis::hazard::HazardClass;

/// Percent Flicker of the ROI luma trace (Michelson contrast x 100) at or
/// above which the flicker is taken as visible on a monitor.
///
/// Why 2 %: the threshold modulation of the eye for flicker at photopic
/// levels is about 0.5-1 % between 5 and 20 Hz and 1-2 % at 1 Hz (de Lange
/// 1958; Kelly 1961, JOSA 51). 2 % is the upper end, so a class is
/// claimed only where an observer would see the flicker at every rate
/// classified here; an 8-bit display step at mid grey is about 0.4 %.
pub const VISIBLE_PERCENT_FLICKER: f64 = 2.0;

/// The named bands, `[lo, hi]` in Hz, with their sources.
pub const BANDS: [(HazardClass, f64, f64, &str); 4] = [
    (
        HazardClass::TrafficSignalLike,
        0.8,
        1.0,
        "US MUTCD 2009 section 4D.30: 50-60 flashes/min",
    ),
    (
        HazardClass::TurnIndicatorLike,
        1.0,
        2.0,
        "UN R6 / R48 section 6.5.7: 90 +/- 30 flashes/min",
    ),
    (
        HazardClass::BeaconLike,
        1.0,
        4.0,
        "SAE J845: 60-240 flashes/min",
    ),
    (
        HazardClass::PeakAnnoyance,
        10.0,
        25.0,
        "de Lange 1958, Kelly 1961; IEEE 1789-2015 section 4",
    ),
];

/// The class of a flicker with apparent frequency `apparent_hz` (>= 0) and
/// Percent Flicker `percent_flicker` of the luma trace (`None` when
/// undefined: no light, taken as not visible), plus every named band the
/// frequency falls in (bands overlap: 1-2 Hz is turn-indicator-like and
/// beacon-like).
pub fn classify(apparent_hz: f64, percent_flicker: Option<f64>) -> (HazardClass, Vec<HazardClass>) {
    let visible = percent_flicker.is_some_and(|p| p >= VISIBLE_PERCENT_FLICKER);
    if !visible || apparent_hz <= 0.0 {
        return (HazardClass::Steady, Vec::new());
    }
    let matches: Vec<HazardClass> = BANDS
        .iter()
        .filter(|(_, lo, hi, _)| apparent_hz >= *lo && apparent_hz <= *hi)
        .map(|(c, ..)| *c)
        .collect();
    let class = if apparent_hz < 0.8 {
        HazardClass::SlowDrift
    } else if apparent_hz < 1.0 {
        HazardClass::TrafficSignalLike
    } else if apparent_hz <= 2.0 {
        HazardClass::TurnIndicatorLike
    } else if apparent_hz <= 4.0 {
        HazardClass::BeaconLike
    } else if (10.0..=25.0).contains(&apparent_hz) {
        HazardClass::PeakAnnoyance
    } else {
        HazardClass::Flicker
    };
    (class, matches)
}

#[cfg(test)]
mod tests {
    use super::*;
    use HazardClass::*;

    #[test]
    fn invisible_or_locked_flicker_is_steady() {
        assert_eq!(classify(1.5, Some(1.9)).0, Steady);
        assert_eq!(classify(1.5, None).0, Steady);
        assert_eq!(classify(0.0, Some(80.0)).0, Steady);
        assert_eq!(classify(1.5, Some(2.0)).0, TurnIndicatorLike);
    }

    #[test]
    fn bands_follow_their_sources() {
        // 90 +/- 30 flashes per minute.
        assert_eq!(classify(60.0 / 60.0, Some(50.0)).0, TurnIndicatorLike);
        assert_eq!(classify(120.0 / 60.0, Some(50.0)).0, TurnIndicatorLike);
        assert_eq!(classify(55.0 / 60.0, Some(50.0)).0, TrafficSignalLike);
        assert_eq!(classify(0.5, Some(50.0)).0, SlowDrift);
        assert_eq!(classify(3.0, Some(50.0)).0, BeaconLike);
        assert_eq!(classify(6.0, Some(50.0)).0, Flicker);
        assert_eq!(classify(15.0, Some(50.0)).0, PeakAnnoyance);
        assert_eq!(classify(28.0, Some(50.0)).0, Flicker);
        let (_, m) = classify(1.5, Some(50.0));
        assert_eq!(m, vec![TurnIndicatorLike, BeaconLike]);
        assert_eq!(classify(1.0, Some(50.0)).1.len(), 3);
    }

    #[test]
    fn every_class_lies_in_a_band_that_names_it() {
        for i in 1..3000 {
            let f = i as f64 * 0.01;
            let (c, m) = classify(f, Some(100.0));
            if matches!(
                c,
                TrafficSignalLike | TurnIndicatorLike | BeaconLike | PeakAnnoyance
            ) {
                assert!(m.contains(&c), "{f} Hz: {c:?} not in {m:?}");
            }
        }
    }
}
