//! A stored case's row as the store holds it, read a chunk at a time, and
//! whether it is what storing its judgement again would write
//! (`Store::rejudge` leaves such a case in place).

use rusqlite::params;

use super::{Row, Store, StoreError, sqlite};

/// A case's row as the store holds it, to compare with a [`Row`].
pub(super) struct StoredRow {
    pub(super) id: String,
    pub(super) conditions: [f64; 3],
    pub(super) verdict: String,
    pub(super) bytes: Vec<u8>,
    pub(super) metrics: Vec<(String, String, Option<f64>)>,
}

impl Row {
    /// Whether storing this row, its record not yet deflated, would leave
    /// `stored`, whose record inflates to `plain`, as it is: the same
    /// record, columns and metrics, every double bit for bit. A record
    /// compared inflated is not deflated again only to be compared.
    pub(super) fn same_as(&self, stored: &StoredRow, plain: &[u8]) -> bool {
        let bits = |x: Option<f64>| x.map(f64::to_bits);
        let mut mine: Vec<(&str, &str, Option<u64>)> = self
            .metrics
            .iter()
            .map(|(roi, m, v)| (roi.as_str(), *m, bits(*v)))
            .collect();
        let mut theirs: Vec<(&str, &str, Option<u64>)> = stored
            .metrics
            .iter()
            .map(|(roi, m, v)| (roi.as_str(), m.as_str(), bits(*v)))
            .collect();
        mine.sort_unstable();
        theirs.sort_unstable();
        let conditions = [self.light_lux, self.frequency_hz, self.duty];
        self.bytes == plain
            && self.id == stored.id
            && self.verdict == stored.verdict
            && conditions.map(f64::to_bits) == stored.conditions.map(f64::to_bits)
            && mine == theirs
    }
}

impl Store {
    /// The rows of the stored cases at `positions` (ascending, and with no
    /// stored case between two of them), as stored: two range scans of
    /// the primary keys rather than two lookups a case.
    pub(super) fn read_rows(
        &self,
        positions: &[usize],
    ) -> Result<Vec<(usize, StoredRow)>, StoreError> {
        let (Some(&first), Some(&last)) = (positions.first(), positions.last()) else {
            return Ok(Vec::new());
        };
        let span = params![first as i64, last as i64];
        let sql = sqlite(&self.path);
        let mut q = self
            .conn
            .prepare_cached(
                "SELECT idx, id, light_lux, frequency_hz, duty, verdict, result FROM cases \
                 WHERE idx BETWEEN ?1 AND ?2 ORDER BY idx",
            )
            .map_err(&sql)?;
        // The record is read as any value, so that one stored as another
        // type (text, a number) is named with its case, not as a column.
        let rows: Vec<(usize, StoredRow, Option<Vec<u8>>)> = q
            .query_map(span, |r| {
                let bytes = match r.get_ref("result")? {
                    rusqlite::types::ValueRef::Blob(b) => Some(b.to_vec()),
                    _ => None,
                };
                Ok((
                    r.get::<_, i64>("idx")? as usize,
                    StoredRow {
                        id: r.get("id")?,
                        conditions: [r.get("light_lux")?, r.get("frequency_hz")?, r.get("duty")?],
                        verdict: r.get("verdict")?,
                        bytes: Vec::new(),
                        metrics: Vec::new(),
                    },
                    bytes,
                ))
            })
            .map_err(&sql)?
            .collect::<Result<_, _>>()
            .map_err(&sql)?;
        let mut out = Vec::with_capacity(rows.len());
        for (idx, mut row, bytes) in rows {
            row.bytes = bytes.ok_or_else(|| StoreError::Record {
                path: self.path.clone(),
                idx,
                id: row.id.clone(),
                message: "its record (the `result` column) is not a BLOB".to_string(),
            })?;
            out.push((idx, row));
        }
        let mut m = self
            .conn
            .prepare_cached(
                "SELECT idx, roi, metric, value FROM roi_metrics \
                 WHERE idx BETWEEN ?1 AND ?2 ORDER BY idx",
            )
            .map_err(&sql)?;
        let metrics = m
            .query_map(span, |r| {
                Ok((
                    r.get::<_, i64>("idx")? as usize,
                    (r.get("roi")?, r.get("metric")?, r.get("value")?),
                ))
            })
            .map_err(&sql)?;
        let mut at = 0;
        for metric in metrics {
            let (idx, metric) = metric.map_err(&sql)?;
            while out.get(at).is_some_and(|(i, _)| *i < idx) {
                at += 1;
            }
            // A metric row with no case row is no part of any stored case.
            if let Some((i, row)) = out.get_mut(at)
                && *i == idx
            {
                row.metrics.push(metric);
            }
        }
        Ok(out)
    }
}
