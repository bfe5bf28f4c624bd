//! Which cases a report shows, and how: a page, a row of the per-case
//! tables, or only the matrices, summary.csv, results.json and the case
//! store. A report of a few hundred cases lists every case; a sweep of
//! thousands summarises, so that its PDF stays a report a person reads
//! (docs/report.md, "Large runs").
//!
//! Part of the results model: computed from the cases' verdicts and
//! checks, so a report rendered again from results.json shows the same.

use std::collections::BTreeSet;

use super::{CaseInfo, Cases, Detail, Results, Verdict};

/// Most case pages a report gives at `--detail standard` (failing cases,
/// worst first); `--detail full` gives every case a page. The per-case
/// tables (failing cases, informational cases, case seeds, Appendix A) of
/// a run of at most [`EVERY_CASE_LISTED_MAX`] cases list every case; a
/// larger run's list its worst [`LISTED_CASES_MAX`] and say where the rest
/// are. The plan's work estimate counts on these.
pub use crate::plan::bounds::{CASE_PAGES_MAX, EVERY_CASE_LISTED_MAX, LISTED_CASES_MAX};

/// The cases a report shows, by id.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Listing {
    /// Cases with a page of their own.
    pub pages: BTreeSet<String>,
    /// Cases in the per-case tables; every page's case is one of them.
    pub listed: BTreeSet<String>,
    /// Cases that would have had a page at this detail but are beyond
    /// [`CASE_PAGES_MAX`].
    pub pages_omitted: usize,
    /// Cases not in the per-case tables.
    pub unlisted: usize,
}

impl Listing {
    /// Whether the report draws the case's own charts (trace, zoom, phase
    /// folds, worst phase): every case of a run that lists every case, else
    /// the cases with a page.
    pub fn charts_case(&self, id: &str) -> bool {
        self.unlisted == 0 || self.pages.contains(id)
    }
}

impl Results {
    /// The `--detail` the report was written with (`report.detail`;
    /// reports written before it existed are `full`).
    pub fn report_detail(&self) -> Detail {
        match self.report.as_ref().map(|r| r.detail.as_str()) {
            Some("") | None => Detail::Full,
            Some(s) => Detail::parse(s).unwrap_or_default(),
        }
    }
}

/// Drops what only a case's own charts read (its phase folds' bins) from
/// the cases whose charts a report at `detail` does not draw
/// ([`Listing::charts_case`]): a large run's model then holds what
/// results.json says of each case, not the data of pictures never drawn.
/// (A spilled run's builder, [`super::CasesBuilder`], drops them as the
/// cases are analysed; this covers the cases kept in memory.)
pub fn drop_undrawn(model: &mut Results, detail: Detail) {
    let listing = listing(model, detail);
    if listing.unlisted == 0 {
        return;
    }
    for c in (model.cases.resident_mut()).filter(|c| !listing.charts_case(&c.id)) {
        drop_chart_data(c);
    }
}

pub(super) fn drop_chart_data(c: &mut CaseInfo) {
    for roi in &mut c.rois {
        roi.analysis.folded_bins = Vec::new();
    }
}

/// How far a case is from failing, worst first: failing cases before
/// informational ones before passing ones, each by the smallest margin of
/// its checks ([`crate::metrics::Check::margin`]).
pub(super) fn rank(c: &CaseInfo) -> (u8, f64) {
    let class = match c.verdict {
        Verdict::Fail => 0,
        Verdict::Info => 1,
        Verdict::Pass => 2,
    };
    let margin = c
        .checks
        .iter()
        .map(|k| k.margin())
        .fold(f64::INFINITY, f64::min);
    (class, margin)
}

/// The cases a report of `results` at `detail` shows.
pub fn listing(results: &Results, detail: Detail) -> Listing {
    listing_of(&results.cases, detail)
}

fn listing_of(cases: &Cases, detail: Detail) -> Listing {
    let key = format!("listing/{}", detail.as_str());
    cases.memo(&key, || compute_listing(cases, detail))
}

fn compute_listing(cases: &Cases, detail: Detail) -> Listing {
    // Each case's rank and whether the detail pages it, in plan order; the
    // ids only of the cases shown.
    let mut order: Vec<(usize, (u8, f64), bool)> = cases
        .iter()
        .enumerate()
        .map(|(i, c)| (i, rank(&c), detail.shows_case(c.verdict.as_str())))
        .collect();
    // A stable sort: equal ranks keep plan order.
    order.sort_by(|(_, (ca, ma), _), (_, (cb, mb), _)| ca.cmp(cb).then(ma.total_cmp(mb)));
    let id = |i: usize| cases.get(i).map(|c| c.id.clone()).unwrap_or_default();
    let paged: Vec<usize> = order.iter().filter(|o| o.2).map(|o| o.0).collect();
    let keep = match detail {
        Detail::Full => paged.len(),
        _ => paged.len().min(CASE_PAGES_MAX),
    };
    let pages: BTreeSet<String> = paged[..keep].iter().map(|&i| id(i)).collect();
    let listed: BTreeSet<String> = if cases.len() <= EVERY_CASE_LISTED_MAX {
        cases.iter().map(|c| c.id.clone()).collect()
    } else {
        let mut listed = pages.clone();
        for &(i, _, _) in &order {
            if listed.len() >= LISTED_CASES_MAX.max(pages.len()) {
                break;
            }
            listed.insert(id(i));
        }
        listed
    };
    Listing {
        pages_omitted: paged.len() - keep,
        unlisted: cases.len() - listed.len(),
        pages,
        listed,
    }
}

#[cfg(test)]
mod tests {
    use super::super::CasesBuilder;
    use super::super::limits::tests::{case, check};
    use super::*;

    /// `n` cases `c0000`...: case `i` fails when `fails(i)` with FDI
    /// `i / n` against a limit of 1, else passes; every tenth is
    /// informational.
    fn cases(n: usize, fails: impl Fn(usize) -> bool) -> Vec<CaseInfo> {
        (0..n)
            .map(|i| {
                let value = if fails(i) { i as f64 / n as f64 } else { 2.0 };
                let mut c = case(vec![check("led", "fdi_2018", Some(value), true, 1.0)]);
                c.id = format!("c{i:04}");
                c.verdict = match (i % 10, fails(i)) {
                    (0, _) => Verdict::Info,
                    (_, true) => Verdict::Fail,
                    (_, false) => Verdict::Pass,
                };
                c
            })
            .collect()
    }

    #[test]
    fn a_run_within_the_list_limit_lists_every_case_and_pages_its_failures() {
        let all = cases(EVERY_CASE_LISTED_MAX, |i| i % 13 == 1);
        let failing = all.iter().filter(|c| c.verdict == Verdict::Fail).count();
        assert!(failing > 0 && failing <= CASE_PAGES_MAX, "{failing}");
        let l = listing_of(&all.clone().into(), Detail::Standard);
        assert_eq!(l.listed.len(), EVERY_CASE_LISTED_MAX);
        assert_eq!((l.unlisted, l.pages_omitted), (0, 0));
        assert_eq!(l.pages.len(), failing);
        assert!(all.iter().all(|c| l.charts_case(&c.id)));
        assert!(
            listing_of(&all.clone().into(), Detail::Summary)
                .pages
                .is_empty()
        );
        assert_eq!(
            listing_of(&all.clone().into(), Detail::Full).pages.len(),
            all.len()
        );
    }

    /// An LED ROI named as the checks of [`cases`] name it.
    fn led_roi() -> super::super::RoiInfo {
        serde_json::from_value(serde_json::json!({
            "name": "led", "kind": "led", "metrics": {}, "reasons": {},
            "levels": {"off": 0.0, "on": 1.0, "min": 0.0, "max": 2.0, "mean": 1.0},
            "saturated": false, "contrast_unbounded": false,
            "analysis": {"apparent_frequency_spectrum_hz": 10.0, "spectrum_reason": null,
                "apparent_frequency_hz": 10.0, "apparent_method": "frame-times",
                "hazard_class": "peak-annoyance", "hazard_matches": [],
                "phase_coverage": {"bins": 64, "covered_bins": 3, "coverage": 0.05,
                    "capture_s": 3.0, "needed_capture_s": null, "worst_case_seen": false,
                    "warning": null}}
        }))
        .unwrap()
    }

    #[test]
    fn a_spilled_run_reads_back_every_case_and_keeps_chart_data_for_exactly_the_paged_cases() {
        let n = EVERY_CASE_LISTED_MAX + 3 * LISTED_CASES_MAX + 7;
        // Failing cases spread over the run, the worst (lowest FDI) late
        // and early alike, so that the best so far changes chunk by chunk.
        let fails = |i: usize| !i.is_multiple_of(3);
        for detail in Detail::ALL {
            let mut all = cases(n, fails);
            for (i, c) in all.iter_mut().enumerate() {
                let mut roi = led_roi();
                roi.analysis.folded_bins = vec![Some((0.0, 1.0))];
                c.rois = vec![roi];
                // Reverse the margins in the second half: later cases worse.
                if i > n / 2 {
                    for k in &mut c.checks {
                        k.value = k.value.map(|v| v - 1.0);
                    }
                }
            }
            let mut built = CasesBuilder::new(n, detail, false).unwrap();
            for chunk in all.chunks(61) {
                built.extend(chunk.to_vec()).unwrap();
            }
            let built = built.finish().unwrap();
            assert_eq!(built.is_spilled(), detail != Detail::Full);
            assert_eq!(built.len(), n);
            // Every case reads back as results.json holds it, in order.
            let json = |c: &CaseInfo| serde_json::to_string(c).unwrap();
            assert_eq!(built.iter().count(), n);
            for (i, (c, b)) in all.iter().zip(&built).enumerate() {
                assert_eq!(json(&b), json(c), "{i}");
            }
            assert_eq!(built.read_error(), None);
            assert_eq!(
                listing_of(&built, detail),
                listing_of(&all.clone().into(), detail)
            );
            let kept: BTreeSet<String> = built
                .iter()
                .filter(|c| c.rois.iter().any(|r| !r.analysis.folded_bins.is_empty()))
                .map(|c| c.id.clone())
                .collect();
            let l = listing_of(&all.clone().into(), detail);
            let charted: BTreeSet<String> = all
                .iter()
                .filter(|c| l.charts_case(&c.id))
                .map(|c| c.id.clone())
                .collect();
            assert_eq!(kept, charted, "{detail:?}");
        }
    }

    #[test]
    fn a_sweep_pages_and_lists_its_worst_cases_only() {
        let n = EVERY_CASE_LISTED_MAX + 4 * LISTED_CASES_MAX;
        // Every third case fails, furthest beyond the limit at low i.
        let all = cases(n, |i| i % 3 == 2);
        let failing: Vec<&CaseInfo> = all.iter().filter(|c| c.verdict == Verdict::Fail).collect();
        let l = listing_of(&all.clone().into(), Detail::Standard);
        assert_eq!(l.pages.len(), CASE_PAGES_MAX);
        assert_eq!(l.pages_omitted, failing.len() - CASE_PAGES_MAX);
        // The pages are the failing cases furthest beyond the limit: the
        // lowest FDI, so the first failing cases in plan order.
        let worst: BTreeSet<String> = failing[..CASE_PAGES_MAX]
            .iter()
            .map(|c| c.id.clone())
            .collect();
        assert_eq!(l.pages, worst);
        assert_eq!(l.listed.len(), LISTED_CASES_MAX);
        assert_eq!(l.unlisted, n - LISTED_CASES_MAX);
        assert!(l.pages.is_subset(&l.listed));
        // More failing cases than the list holds: it lists failing cases only.
        assert!(failing.len() > LISTED_CASES_MAX);
        assert!(
            all.iter()
                .filter(|c| l.listed.contains(&c.id))
                .all(|c| c.verdict == Verdict::Fail)
        );
        assert!(!l.charts_case("c0000") && l.charts_case(&failing[0].id));
        // Full detail pages every case, and lists every paged case.
        let full = listing_of(&all.clone().into(), Detail::Full);
        assert_eq!(full.pages.len(), n);
        assert_eq!(full.pages_omitted, 0);
        assert!(full.pages.is_subset(&full.listed));
    }
}
