//! The cases of a results model. A run whose report lists every case
//! holds them in memory. A larger run (a sweep of thousands) writes each
//! case, as results.json holds it, to a spill file while the cases are
//! analysed, and keeps in memory only the cases its report can list or
//! page and those with a worst-phase run (whose frames and trace are not
//! in results.json): its model's memory then does not grow with the number
//! of cases (docs/report.md, "Large runs").
//!
//! Reading the spill back is the run's own file, written moments before;
//! a read that fails anyway ends the iteration early and is kept, and the
//! pipeline refuses to commit a report while [`Cases::read_error`] holds
//! one, so a short iteration never reaches a user.

use std::borrow::Cow;
use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::os::unix::fs::FileExt;
use std::sync::{Arc, Mutex};

use serde::{Deserialize, Serialize};

use super::listing::{CASE_PAGES_MAX, EVERY_CASE_LISTED_MAX, LISTED_CASES_MAX, rank};
use super::{CaseInfo, Detail};

/// Every case of a run, in plan order.
#[derive(Clone, Default)]
pub struct Cases {
    repr: Repr,
    /// The cases results.json holds whole; the others are summary rows
    /// ([`super::row`]). `None`: every case whole.
    detailed: Option<Arc<std::collections::BTreeSet<String>>>,
    /// The ROI map's cases as [`CasesBuilder`] chose them, while it saw
    /// every case; `None` for cases that did not come through it.
    map: Option<MapChoice>,
}

/// The cases the report's ROI map shows (docs/report.md), chosen as the
/// cases go by in plan order: every case with a sample frame when
/// `every_framed` (a captured run: one case per file), else the one case
/// whose sample frame is brightest ([`CaseInfo::sample_frame_led_level`]),
/// the first of equals. This is the one place the rule is written:
/// [`CasesBuilder`] keeps these cases in memory, and the report's figure
/// and its list of shown cases read the same choice ([`Cases::map_cases`]).
#[derive(Clone, Debug)]
pub struct MapChoice {
    every_framed: bool,
    /// Positions and sample-frame levels of the cases chosen so far.
    chosen: Vec<(usize, f64)>,
}

impl MapChoice {
    /// No case chosen yet.
    pub fn new(every_framed: bool) -> MapChoice {
        MapChoice {
            every_framed,
            chosen: Vec::new(),
        }
    }

    /// Offers the case at position `i`, after every case before it.
    pub fn offer(&mut self, i: usize, c: &CaseInfo) {
        if c.sample_frame.is_some() {
            self.offer_level(i, c.sample_frame_led_level());
        }
    }

    /// Offers position `i` with a frame whose LED ROI's level is `level`.
    pub fn offer_level(&mut self, i: usize, level: f64) {
        if self.every_framed {
            self.chosen.push((i, level));
        } else if self.chosen.first().is_none_or(|&(_, best)| level > best) {
            self.chosen.clear();
            self.chosen.push((i, level));
        }
    }

    /// Whether position `i` is chosen.
    pub fn contains(&self, i: usize) -> bool {
        self.chosen.iter().any(|&(k, _)| k == i)
    }

    /// The chosen positions, in plan order.
    pub fn positions(&self) -> Vec<usize> {
        self.chosen.iter().map(|&(k, _)| k).collect()
    }
}

#[derive(Clone)]
enum Repr {
    Memory(Vec<CaseInfo>),
    Spilled {
        /// The cases kept in memory, by position; they stand in for their
        /// spilled copies, which lack what results.json does not hold.
        resident: BTreeMap<usize, CaseInfo>,
        spill: Arc<Spill>,
    },
}

impl Default for Repr {
    fn default() -> Repr {
        Repr::Memory(Vec::new())
    }
}

/// The spill file: each case's JSON, as results.json holds it (floats
/// written exactly, `serde_json`'s `float_roundtrip`), one after the other.
struct Spill {
    file: File,
    /// Offset of each case's record; a record ends where the next starts,
    /// the last at `end`.
    starts: Vec<u64>,
    end: u64,
    /// The first read that failed.
    failed: Mutex<Option<String>>,
    /// What [`Cases::memo`] computed, by key: each costs a pass over the
    /// spill, and the report asks for some of them many times.
    memo: Mutex<std::collections::HashMap<String, Arc<dyn std::any::Any + Send + Sync>>>,
}

impl Spill {
    /// Where case `i`'s record is in the file.
    fn span(&self, i: usize) -> std::ops::Range<u64> {
        self.starts[i]..self.starts.get(i + 1).copied().unwrap_or(self.end)
    }

    /// Where case `i`'s record is in a block read from file offset `first`.
    fn range(&self, i: usize, first: u64) -> std::ops::Range<usize> {
        let span = self.span(i);
        (span.start - first) as usize..(span.end - first) as usize
    }

    /// The records of the cases `block`, read at once, and the file offset
    /// they start at.
    fn read_block(&self, block: std::ops::Range<usize>) -> Result<(Vec<u8>, u64), String> {
        let (first, end) = (self.span(block.start).start, self.span(block.end - 1).end);
        let mut buf = vec![0; (end - first) as usize];
        self.file.read_exact_at(&mut buf, first).map_err(|e| {
            format!(
                "reading cases {}..{} back from the spill file: {e}",
                block.start + 1,
                block.end
            )
        })?;
        Ok((buf, first))
    }

    fn decode(&self, i: usize, record: &[u8]) -> Result<CaseInfo, String> {
        serde_json::from_slice(record)
            .map_err(|e| format!("decoding case {} of the spill file: {e}", i + 1))
    }

    fn read(&self, i: usize) -> Result<CaseInfo, String> {
        let (record, _) = self.read_block(i..i + 1)?;
        self.decode(i, &record)
    }

    fn fail(&self, why: String) {
        let mut failed = self.failed.lock().unwrap_or_else(|p| p.into_inner());
        failed.get_or_insert(why);
    }
}

impl Cases {
    /// Number of cases.
    pub fn len(&self) -> usize {
        match &self.repr {
            Repr::Memory(v) => v.len(),
            Repr::Spilled { spill, .. } => spill.starts.len(),
        }
    }

    /// Whether there is no case.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Whether the cases are spilled to disk (a run larger than its report
    /// lists).
    pub fn is_spilled(&self) -> bool {
        matches!(self.repr, Repr::Spilled { .. })
    }

    /// The case at `i`: borrowed when in memory, else read back.
    pub fn get(&self, i: usize) -> Option<Cow<'_, CaseInfo>> {
        match &self.repr {
            Repr::Memory(v) => v.get(i).map(Cow::Borrowed),
            Repr::Spilled { resident, spill } => {
                if let Some(c) = resident.get(&i) {
                    return Some(Cow::Borrowed(c));
                }
                if i >= spill.starts.len() {
                    return None;
                }
                match spill.read(i) {
                    Ok(c) => Some(Cow::Owned(c)),
                    Err(why) => {
                        spill.fail(why);
                        None
                    }
                }
            }
        }
    }

    /// Every case in order (see the module's note on failed reads).
    pub fn iter(&self) -> Iter<'_> {
        Iter {
            cases: self,
            next: 0,
            ahead: Default::default(),
        }
    }

    /// The cases held in memory, in order: every case when none is
    /// spilled, else those [`CasesBuilder`] keeps (the ones a report can
    /// list, page or draw a map from, and those with a worst-phase run).
    /// What results.json does not hold of a case (its frames, traces and
    /// chart data) is only in these.
    pub fn resident(&self) -> Box<dyn Iterator<Item = &CaseInfo> + '_> {
        match &self.repr {
            Repr::Memory(v) => Box::new(v.iter()),
            Repr::Spilled { resident, .. } => Box::new(resident.values()),
        }
    }

    /// The cases held in memory, to change what only the report reads
    /// (every case when none is spilled).
    pub fn resident_mut(&mut self) -> Box<dyn Iterator<Item = &mut CaseInfo> + '_> {
        Box::new(self.resident_at_mut().map(|(_, c)| c))
    }

    /// The cases held in memory with their positions in the run, to
    /// change what only the report reads.
    pub fn resident_at_mut(&mut self) -> Box<dyn Iterator<Item = (usize, &mut CaseInfo)> + '_> {
        match &mut self.repr {
            Repr::Memory(v) => Box::new(v.iter_mut().enumerate()),
            Repr::Spilled { resident, .. } => Box::new(resident.iter_mut().map(|(&i, c)| (i, c))),
        }
    }

    /// Positions of the ROI map's cases ([`MapChoice`]): the builder's
    /// choice when it made one by the same rule, else chosen now, over
    /// every case.
    pub fn map_cases(&self, every_framed: bool) -> Vec<usize> {
        if let Some(map) = self.map.as_ref().filter(|m| m.every_framed == every_framed) {
            return map.positions();
        }
        let mut choice = MapChoice::new(every_framed);
        for (i, c) in self.iter().enumerate() {
            choice.offer(i, &c);
        }
        choice.positions()
    }

    /// Every case in memory, to change: a spilled run is read back whole.
    pub fn to_mut(&mut self) -> &mut Vec<CaseInfo> {
        // A change may move the ROI map's choice.
        self.map = None;
        if self.is_spilled() {
            let all: Vec<CaseInfo> = self.iter().map(Cow::into_owned).collect();
            self.repr = Repr::Memory(all);
        }
        match &mut self.repr {
            Repr::Memory(v) => v,
            Repr::Spilled { .. } => unreachable!("read back above"),
        }
    }

    /// Why a case could not be read back from the spill file, if one
    /// could not: what was read since is incomplete.
    pub fn read_error(&self) -> Option<String> {
        match &self.repr {
            Repr::Memory(_) => None,
            Repr::Spilled { spill, .. } => spill
                .failed
                .lock()
                .unwrap_or_else(|p| p.into_inner())
                .clone(),
        }
    }
}

/// The case at `i` when it is in memory (every case of a run that is not
/// spilled). Like a slice's, it panics where `get` gives `None`, and also on
/// a spilled case: code that may meet a spilled run calls [`Cases::get`].
impl std::ops::Index<usize> for Cases {
    type Output = CaseInfo;

    fn index(&self, i: usize) -> &CaseInfo {
        match &self.repr {
            Repr::Memory(v) => &v[i],
            Repr::Spilled { resident, .. } => resident
                .get(&i)
                .unwrap_or_else(|| panic!("case {i} is spilled: read it with `Cases::get`")),
        }
    }
}

impl Cases {
    /// `compute`'s value, a figure of every case: for spilled cases, which
    /// never change, computed once per `key` and kept; for cases in memory,
    /// which are cheap to go over and may change, computed each time.
    pub(super) fn memo<T: Clone + Send + Sync + 'static>(
        &self,
        key: &str,
        compute: impl FnOnce() -> T,
    ) -> T {
        let Repr::Spilled { spill, .. } = &self.repr else {
            return compute();
        };
        let lock = || spill.memo.lock().unwrap_or_else(|p| p.into_inner());
        if let Some(v) = lock().get(key).and_then(|v| v.downcast_ref::<T>()) {
            return v.clone();
        }
        let v = compute();
        lock().insert(key.to_string(), Arc::new(v.clone()));
        v
    }
}

impl From<Vec<CaseInfo>> for Cases {
    fn from(v: Vec<CaseInfo>) -> Cases {
        Cases {
            repr: Repr::Memory(v),
            detailed: None,
            map: None,
        }
    }
}

impl FromIterator<CaseInfo> for Cases {
    fn from_iter<I: IntoIterator<Item = CaseInfo>>(iter: I) -> Cases {
        Cases::from(iter.into_iter().collect::<Vec<_>>())
    }
}

impl std::fmt::Debug for Cases {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match &self.repr {
            Repr::Memory(v) => v.fmt(f),
            Repr::Spilled { resident, .. } => write!(
                f,
                "Cases({} spilled, {} in memory)",
                self.len(),
                resident.len()
            ),
        }
    }
}

/// Cases a spilled iteration reads and decodes at once, in parallel.
const READ_AHEAD: usize = 256;

/// [`Cases::iter`]. Over a spill it reads [`READ_AHEAD`] cases with one
/// read and decodes them in parallel: the passes over a sweep's cases are
/// most of its report stage.
pub struct Iter<'a> {
    cases: &'a Cases,
    next: usize,
    ahead: std::collections::VecDeque<Cow<'a, CaseInfo>>,
}

impl<'a> Iter<'a> {
    /// Reads the cases from `self.next` on into `ahead`; on a failed read,
    /// keeps the error and ends the iteration.
    fn read_ahead(&mut self, resident: &'a BTreeMap<usize, CaseInfo>, spill: &'a Spill) {
        use rayon::prelude::*;
        let block = self.next..(self.next + READ_AHEAD).min(spill.starts.len());
        self.next = block.end;
        let decoded: Result<Vec<Cow<'a, CaseInfo>>, String> =
            spill.read_block(block.clone()).and_then(|(bytes, first)| {
                block
                    .into_par_iter()
                    .map(|i| match resident.get(&i) {
                        Some(c) => Ok(Cow::Borrowed(c)),
                        None => spill
                            .decode(i, &bytes[spill.range(i, first)])
                            .map(Cow::Owned),
                    })
                    .collect()
            });
        match decoded {
            Ok(cases) => self.ahead.extend(cases),
            Err(why) => {
                spill.fail(why);
                self.next = usize::MAX;
            }
        }
    }
}

impl<'a> Iterator for Iter<'a> {
    type Item = Cow<'a, CaseInfo>;

    fn next(&mut self) -> Option<Cow<'a, CaseInfo>> {
        let cases: &'a Cases = self.cases;
        match &cases.repr {
            Repr::Memory(v) => {
                let c = v.get(self.next)?;
                self.next += 1;
                Some(Cow::Borrowed(c))
            }
            Repr::Spilled { resident, spill } => {
                if self.ahead.is_empty() && self.next < spill.starts.len() {
                    self.read_ahead(resident, spill);
                }
                self.ahead.pop_front()
            }
        }
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        let left = self.cases.len().saturating_sub(self.next) + self.ahead.len();
        (0, Some(left))
    }
}

impl<'a> IntoIterator for &'a Cases {
    type Item = Cow<'a, CaseInfo>;
    type IntoIter = Iter<'a>;

    fn into_iter(self) -> Iter<'a> {
        self.iter()
    }
}

impl Serialize for Cases {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::{Error, SerializeSeq};
        struct Row<'a>(&'a CaseInfo);
        impl Serialize for Row<'_> {
            fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
                super::row::serialize_row(self.0, s)
            }
        }
        let mut seq = s.serialize_seq(Some(self.len()))?;
        for c in self {
            match self.is_detailed(&c.id) {
                true => seq.serialize_element(&*c)?,
                false => seq.serialize_element(&Row(&c))?,
            }
        }
        if let Some(why) = self.read_error() {
            return Err(S::Error::custom(why));
        }
        seq.end()
    }
}

impl<'de> Deserialize<'de> for Cases {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Cases, D::Error> {
        use super::row::Entry;
        use serde::de::Error;
        // Each entry is told by its `full_record` key, then read as what it
        // is, so that an error names the field of a whole case or a row
        // (an untagged enum would only say that neither fits).
        let values = Vec::<serde_json::Value>::deserialize(d)?;
        let entries = values
            .into_iter()
            .enumerate()
            .map(|(i, v)| {
                let entry = match v.get("full_record").is_some() {
                    true => serde_json::from_value(v).map(Entry::Row),
                    false => serde_json::from_value(v).map(Entry::Full),
                };
                entry.map_err(|e| D::Error::custom(format!("case {}: {e}", i + 1)))
            })
            .collect::<Result<Vec<Entry>, D::Error>>()?;
        let rows = entries.iter().any(|e| matches!(e, Entry::Row(_)));
        let detailed = rows.then(|| {
            let whole = entries.iter().filter_map(|e| match e {
                Entry::Full(c) => Some(c.id.clone()),
                Entry::Row(_) => None,
            });
            Arc::new(whole.collect())
        });
        let cases: Vec<CaseInfo> = entries
            .into_iter()
            .map(|e| match e {
                Entry::Full(c) => *c,
                Entry::Row(r) => r.into_case(),
            })
            .collect();
        Ok(Cases {
            detailed,
            ..Cases::from(cases)
        })
    }
}

impl Cases {
    /// Whether results.json holds case `id` whole, rather than as a
    /// summary row whose full record is in the case store.
    pub fn is_detailed(&self, id: &str) -> bool {
        self.detailed.as_ref().is_none_or(|d| d.contains(id))
    }

    /// Whether some case is a summary row.
    pub fn has_rows(&self) -> bool {
        self.detailed.as_ref().is_some_and(|d| d.len() < self.len())
    }

    /// Writes only the cases `ids` whole to results.json, every other as
    /// its summary row; `None` writes every case whole.
    pub fn set_detailed(&mut self, ids: Option<std::collections::BTreeSet<String>>) {
        self.detailed = ids.map(Arc::new);
    }
}

/// Builds a run's [`Cases`] as its cases are analysed, a chunk at a time,
/// for a report at `detail`. A run of at most [`EVERY_CASE_LISTED_MAX`]
/// cases, or one whose every case gets a page (`--detail full`), is held
/// in memory whole. A larger one is spilled, keeping in memory the cases
/// that can still be listed (best [`LISTED_CASES_MAX`] so far by the
/// listing's order) or paged (best [`CASE_PAGES_MAX`] of those the detail
/// pages), every case with a worst-phase run, and the case whose sample
/// frame is brightest (every one with `every_framed`: a capture's, one per
/// file) for the report's ROI map. Of the cases in memory
/// only those that can still get a page keep the data of their charts
/// (their phase folds' bins): a case pushed out never comes back, since
/// the cases kept only get worse.
pub struct CasesBuilder {
    detail: Detail,
    /// The cases kept for the ROI map.
    map: MapChoice,
    /// Cases seen so far.
    seen: usize,
    repr: Building,
}

enum Building {
    Memory(Vec<CaseInfo>),
    Spilling {
        out: BufWriter<File>,
        starts: Vec<u64>,
        at: u64,
        resident: BTreeMap<usize, CaseInfo>,
        /// Positions of the best cases so far for the listing, best first.
        listed: Vec<usize>,
        /// The same, of the cases the detail pages.
        paged: Vec<usize>,
    },
}

impl CasesBuilder {
    /// For a run of `total` cases reported at `detail`; the spill file (when
    /// the run needs one) is an unnamed temporary file, gone when the model
    /// is dropped.
    pub fn new(total: usize, detail: Detail, every_framed: bool) -> std::io::Result<CasesBuilder> {
        let repr = if detail == Detail::Full || total <= EVERY_CASE_LISTED_MAX {
            Building::Memory(Vec::with_capacity(total))
        } else {
            Building::Spilling {
                out: BufWriter::new(tempfile::tempfile()?),
                starts: Vec::with_capacity(total),
                at: 0,
                resident: BTreeMap::new(),
                listed: Vec::new(),
                paged: Vec::new(),
            }
        };
        Ok(CasesBuilder {
            detail,
            map: MapChoice::new(every_framed),
            seen: 0,
            repr,
        })
    }

    /// Whether the cases are spilled: only some are kept in memory, and
    /// of the others only their summary rows are ever read.
    pub fn spills(&self) -> bool {
        matches!(self.repr, Building::Spilling { .. })
    }

    /// Appends the next cases, in order.
    pub fn extend(&mut self, cases: Vec<CaseInfo>) -> std::io::Result<()> {
        let detail = self.detail;
        let map = &mut self.map;
        for (k, c) in cases.iter().enumerate() {
            map.offer(self.seen + k, c);
        }
        self.seen += cases.len();
        let Building::Spilling {
            out,
            starts,
            at,
            resident,
            listed,
            paged,
        } = &mut self.repr
        else {
            if let Building::Memory(v) = &mut self.repr {
                v.extend(cases);
            }
            return Ok(());
        };
        let mut record = Vec::new();
        for c in cases {
            record.clear();
            serde_json::to_writer(&mut record, &c).map_err(std::io::Error::other)?;
            out.write_all(&record)?;
            let i = starts.len();
            starts.push(*at);
            *at += record.len() as u64;
            listed.push(i);
            if detail.shows_case(c.verdict.as_str()) {
                paged.push(i);
            }
            resident.insert(i, c);
        }
        let by_rank = |&a: &usize, &b: &usize| {
            let ((ca, ma), (cb, mb)) = (rank(&resident[&a]), rank(&resident[&b]));
            ca.cmp(&cb).then(ma.total_cmp(&mb)).then(a.cmp(&b))
        };
        listed.sort_by(by_rank);
        listed.truncate(LISTED_CASES_MAX);
        paged.sort_by(by_rank);
        paged.truncate(CASE_PAGES_MAX);
        resident.retain(|i, c| {
            let page = paged.contains(i);
            if !page {
                super::listing::drop_chart_data(c);
            }
            page || listed.contains(i) || c.worst_phase.is_some() || map.contains(*i)
        });
        Ok(())
    }

    /// The cases.
    pub fn finish(self) -> std::io::Result<Cases> {
        let repr = match self.repr {
            Building::Memory(v) => Repr::Memory(v),
            Building::Spilling {
                out,
                starts,
                at,
                resident,
                ..
            } => {
                let file = out.into_inner().map_err(|e| e.into_error())?;
                Repr::Spilled {
                    resident,
                    spill: Arc::new(Spill {
                        file,
                        starts,
                        end: at,
                        failed: Mutex::new(None),
                        memo: Mutex::default(),
                    }),
                }
            }
        };
        Ok(Cases {
            repr,
            detailed: None,
            map: Some(self.map),
        })
    }
}
