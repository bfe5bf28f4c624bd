//! Notes that several case pages of the PDF would print word for word: a
//! beat explained, a phase fold not drawn, a coverage warning, a spectrum
//! or banding estimate that could not be made, the banding of the frame
//! shown. A sweep's failing cases are often neighbours on its grid, so
//! their pages say the same things; the PDF says each such note once,
//! above the cases, and a page refers to it by number.

use std::collections::BTreeMap;

use super::Document;
use crate::model::RoiKind;
use crate::model::SampleFrameInfo;
use crate::model::frame::{
    CROP_ZOOM, STRETCH_HIGH_PERCENTILE, STRETCH_LOW_PERCENTILE, banding_sentence, roi_key,
};

/// Fewest case pages a note must be on to be said once above them: on two
/// pages a note is easier read where it applies.
const COMMON_MIN_PAGES: usize = 3;

/// The notes said once above the case pages, and how a page prints each
/// note that holds one of them.
#[derive(Debug, Default, serde::Serialize)]
pub struct CommonNotes {
    /// Clause -> its number, from 1.
    pub said_once: BTreeMap<String, usize>,
    /// A page's note -> the note with each clause said once replaced by
    /// "note N".
    pub shortened: BTreeMap<String, String>,
}

/// Fewest alphabetic words a clause must have to be said once: a short
/// clause costs less to repeat than to look up.
const COMMON_MIN_WORDS: usize = 6;

/// The clauses of `note`: its parts between "; ".
fn clauses(note: &str) -> impl Iterator<Item = &str> {
    note.split("; ")
}

fn words(clause: &str) -> usize {
    clause
        .split_whitespace()
        .filter(|w| w.chars().all(char::is_alphabetic))
        .count()
}

impl Document {
    /// The clauses of the case pages' notes ([`Document::page_notes`])
    /// printed on at least [`COMMON_MIN_PAGES`] of them, numbered from 1
    /// in the order the pages first print them, and each note that holds
    /// one as the page prints it.
    pub fn common_notes(&self) -> CommonNotes {
        let pages = self.page_notes();
        let mut counts: Vec<(&str, usize)> = Vec::new();
        for notes in pages.values() {
            let mut seen: Vec<&str> = Vec::new();
            for clause in notes.iter().flat_map(|n| clauses(n)) {
                if seen.contains(&clause) || words(clause) < COMMON_MIN_WORDS {
                    continue;
                }
                seen.push(clause);
                match counts.iter_mut().find(|(c, _)| *c == clause) {
                    Some((_, count)) => *count += 1,
                    None => counts.push((clause, 1)),
                }
            }
        }
        let said_once: BTreeMap<String, usize> = counts
            .into_iter()
            .filter(|(_, count)| *count >= COMMON_MIN_PAGES)
            .enumerate()
            .map(|(i, (clause, _))| (clause.to_string(), i + 1))
            .collect();
        let mut shortened = BTreeMap::new();
        for note in pages.values().flatten() {
            if clauses(note).any(|c| said_once.contains_key(c)) {
                let short: Vec<String> = clauses(note)
                    .map(|c| match said_once.get(c) {
                        Some(n) => format!("note {n}"),
                        None => c.to_string(),
                    })
                    .collect();
                shortened.insert(note.clone(), short.join("; "));
            }
        }
        CommonNotes {
            said_once,
            shortened,
        }
    }

    /// Each case page's notes, in page order, each in the order its page
    /// prints them. The banding sentences of its frames are here too
    /// ([`Document::frame_captions`]).
    fn page_notes(&self) -> BTreeMap<usize, Vec<String>> {
        let pages = self.case_pages();
        let mut folds = self.fold_notes();
        let mut caveats = self.caveats();
        let mut out = BTreeMap::new();
        let paged = (self.results.cases.resident()).filter(|c| pages.contains(&c.id));
        for (k, c) in paged.enumerate() {
            let mut notes = caveats.remove(&c.id).unwrap_or_default();
            notes.push(c.beat.note.clone());
            let leds = c.rois.iter().filter(|r| r.kind == RoiKind::Led);
            for roi in leds {
                notes.extend(roi.analysis.spectrum_reason.clone());
                notes.extend(roi.analysis.phase_coverage.warning.clone());
            }
            if let Some(b) = &c.banding {
                notes.extend(b.estimate_note.clone());
            }
            if let Some(f) = &c.sample_frame {
                notes.push(banding_sentence(f.banding.as_ref()));
            }
            notes.extend(folds.remove(&c.id).unwrap_or_default());
            if let Some(f) = c.worst_phase.as_ref().and_then(|w| w.sample_frame.as_ref()) {
                notes.push(banding_sentence(f.banding.as_ref()));
            }
            out.insert(k, notes);
        }
        out
    }

    /// How to read the frames of the case pages, said once above them:
    /// the display stretch, the ROIs' numbers, the crop. `None` when no
    /// case page shows a frame.
    pub fn frame_key(&self) -> Option<String> {
        let pages = self.case_pages();
        let frame = (self.results.cases.resident())
            .filter(|c| pages.contains(&c.id))
            .find_map(|c| c.sample_frame.as_ref())?;
        let key = roi_key(&frame.rois);
        Some(format!(
            "Each case page shows a frame display-stretched: its {STRETCH_LOW_PERCENTILE}th percentile of luma black and its {STRETCH_HIGH_PERCENTILE}th white, linearly in between (darker and brighter pixels clipped). ROIs: {}. Right of the frame: the region around the LED ROI (yellow box) at {CROP_ZOOM}x. Each caption gives the levels shown black and white, and the region's size and top-left pixel (column, row).",
            key.join(", ")
        ))
    }

    /// The PDF's caption of each case's frame (of its frame at the worst
    /// phase with `worst`), by case id: the stretch and the crop as
    /// numbers ([`Document::frame_key`] says what they mean), then the
    /// sentence on the frame's banding.
    pub fn frame_captions(&self, worst: bool) -> BTreeMap<String, [String; 2]> {
        let listing = self.listing();
        (self.results.cases.resident())
            .filter(|c| listing.listed.contains(&c.id))
            .filter_map(|c| {
                let frame = if worst {
                    c.worst_phase.as_ref()?.sample_frame.as_ref()?
                } else {
                    c.sample_frame.as_ref()?
                };
                Some((
                    c.id.clone(),
                    [numbers(frame), banding_sentence(frame.banding.as_ref())],
                ))
            })
            .collect()
    }
}

/// The stretch and the crop of `frame`, as numbers.
fn numbers(frame: &SampleFrameInfo) -> String {
    let fixed = |v: f64| crate::util::fixed(v, 1);
    let mut out = format!(
        "Black–white: {}–{} DN",
        fixed(frame.stretch.low_dn),
        fixed(frame.stretch.high_dn)
    );
    if let Some([x, y, w, h]) = frame.crop_px {
        out.push_str(&format!("; region: {w} × {h} px at ({x}, {y})"));
    }
    out.push('.');
    out
}
