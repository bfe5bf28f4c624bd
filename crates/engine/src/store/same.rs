//! Whether a stored case's row is what storing its judgement again would
//! write (`Store::rejudge` leaves such a case in place).

use super::Row;

/// A case's row as the store holds it, to compare with a [`Row`].
pub(super) struct StoredRow {
    pub(super) id: String,
    pub(super) conditions: [f64; 3],
    pub(super) verdict: String,
    pub(super) bytes: Vec<u8>,
    pub(super) metrics: Vec<(String, String, Option<f64>)>,
}

impl Row {
    /// Whether storing this row would leave `stored` as it is: the same
    /// record, columns and metrics, every double bit for bit.
    pub(super) fn same_as(&self, stored: &StoredRow) -> bool {
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
        self.bytes == stored.bytes
            && self.id == stored.id
            && self.verdict == stored.verdict
            && conditions.map(f64::to_bits) == stored.conditions.map(f64::to_bits)
            && mine == theirs
    }
}
