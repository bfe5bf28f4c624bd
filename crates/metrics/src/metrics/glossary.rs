//! The names a person reads for each metric id of results.json.
//!
//! results.json, the CSV exports and `--golden-tolerance` keep the snake_case ids
//! (`fdi_2018_worst_phase`); every table and chart of the HTML and PDF
//! reports shows [`human_name`] instead, and the reports' glossary lists
//! [`GLOSSARY`] so that an id seen in results.json can be found. One table,
//! so the two reports and the charts never name a metric differently.

/// A metric as a reader meets it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct MetricName {
    /// Id in results.json, e.g. `fdi_2018_worst_phase`.
    pub id: &'static str,
    /// Name in tables and charts, e.g. "FDI (Deegan 2018), worst phase".
    pub name: &'static str,
    /// Abbreviation for a narrow table column, e.g. "FDI 2018 worst";
    /// the glossary spells it out.
    pub short: &'static str,
    /// One-line definition, plain text.
    pub definition: &'static str,
    /// Unit of the value; "1" for a ratio without unit.
    pub unit: &'static str,
}

/// Every metric the reports show, in the order of the glossary.
pub const GLOSSARY: &[MetricName] = &[
    MetricName {
        id: "fdi_2018",
        name: "FDI (Deegan 2018)",
        short: "FDI 2018",
        definition: "Flicker Detection Index: (lowest PWM luma - L_OFF) / L_OFF; below 0.1 the light can appear OFF",
        unit: "1",
    },
    MetricName {
        id: "fdi_2018_worst_phase",
        name: "FDI (Deegan 2018), worst phase",
        short: "FDI 2018 worst",
        definition: "FDI at the PWM phase that gives the lowest luma, over every phase (simulator only)",
        unit: "1",
    },
    MetricName {
        id: "percent_flicker",
        name: "Percent Flicker",
        short: "PF",
        definition: "100 (max - min) / (max + min) of the PWM-segment luma (IEEE 1789-2015)",
        unit: "%",
    },
    MetricName {
        id: "percent_flicker_worst_phase",
        name: "Percent Flicker, worst phase",
        short: "PF worst",
        definition: "Percent Flicker from the lowest and highest luma over every PWM phase (simulator only)",
        unit: "%",
    },
    MetricName {
        id: "fmi",
        name: "Flicker Modulation Index (P2020)",
        short: "FMI",
        definition: "(max - min) / (max + min) of the PWM-segment luma; lower is better",
        unit: "1",
    },
    MetricName {
        id: "fdi_p2020",
        name: "FDI (IEEE P2020)",
        short: "FDI P2020",
        definition: "share of PWM frames in which the light is told from OFF; higher is better",
        unit: "1",
    },
    MetricName {
        id: "mmp",
        name: "Modulation Mitigation Probability (P2020)",
        short: "MMP",
        definition: "share of PWM frames within the tolerance of the reference level; higher is better",
        unit: "1",
    },
    MetricName {
        id: "apparent_frequency_spectrum_hz",
        name: "Apparent frequency (spectrum)",
        short: "f spectrum",
        definition: "strongest frequency of the ROI's PWM-segment trace, as the video shows it",
        unit: "Hz",
    },
    MetricName {
        id: "phase_coverage",
        name: "Phase coverage",
        short: "phase cov.",
        definition: "share of PWM phase bins that the captured frames sample",
        unit: "1",
    },
];

/// The metrics of a plan with `[display]` (docs/visibility.md), listed
/// in a report's glossary after [`GLOSSARY`] only when the plan has one.
pub const VISIBILITY_GLOSSARY: &[MetricName] = &[
    MetricName {
        id: "visibility",
        name: "Visibility on the monitor",
        short: "visible",
        definition: "displayed flicker weighted by the eye's temporal contrast sensitivity (elaTCSF): 1 = at threshold for the standard observer",
        unit: "1",
    },
    MetricName {
        id: "visibility_peak_hz",
        name: "Most visible frequency",
        short: "f visible",
        definition: "frequency of the displayed flicker's component that adds most to the visibility",
        unit: "Hz",
    },
    MetricName {
        id: "display_luminance_cd_m2",
        name: "Displayed luminance",
        short: "L display",
        definition: "mean luminance of the ROI on the monitor over the PWM segment",
        unit: "cd/m^2",
    },
    MetricName {
        id: "visual_radius_deg",
        name: "Visual radius",
        short: "radius",
        definition: "radius of the disk with the visual area of the ROI on the monitor, at the viewing distance",
        unit: "deg",
    },
];

/// Metric `id`'s entry in [`GLOSSARY`] or [`VISIBILITY_GLOSSARY`].
fn entry(id: &str) -> Option<&'static MetricName> {
    GLOSSARY
        .iter()
        .chain(VISIBILITY_GLOSSARY)
        .find(|m| m.id == id)
}

/// The abbreviation of metric `id` for a narrow column ([`human_name`]
/// when it has none in [`GLOSSARY`]).
pub fn short_name(id: &str) -> &str {
    entry(id).map_or(id, |m| m.short)
}

/// The name a person reads for metric `id`; an id not in [`GLOSSARY`] is
/// returned as it is, so a new metric shows up (named by its id) rather
/// than vanishing.
pub fn human_name(id: &str) -> &str {
    entry(id).map_or(id, |m| m.name)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_metric_has_one_distinct_readable_name() {
        for field in [|m: &MetricName| m.name, |m: &MetricName| m.short] {
            let all = GLOSSARY.iter().chain(VISIBILITY_GLOSSARY);
            let mut names: Vec<&str> = all.clone().map(field).collect();
            names.sort_unstable();
            names.dedup();
            assert_eq!(names.len(), all.count(), "two metrics share a name");
        }
        for m in GLOSSARY.iter().chain(VISIBILITY_GLOSSARY) {
            assert!(!m.name.contains('_') && !m.short.contains('_'), "{}", m.id);
            assert!(m.short.chars().count() <= 14, "{} is not short", m.short);
            assert!(!m.definition.is_empty() && !m.unit.is_empty(), "{}", m.id);
            assert_eq!(human_name(m.id), m.name);
            assert_eq!(short_name(m.id), m.short);
        }
        assert_eq!(human_name("not_a_metric"), "not_a_metric");
        assert_eq!(short_name("not_a_metric"), "not_a_metric");
    }
}
