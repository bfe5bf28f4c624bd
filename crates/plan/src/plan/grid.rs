//! Grid expansion: a plan's light levels x frequencies x duty cycles become
//! [`TestCase`]s, in plan order, each with a stable id and its own seed.

use super::Plan;

/// One condition to test: a light level, a PWM frequency and a duty cycle.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TestCase {
    /// Position in the plan's expansion (light-major, then frequency, then duty).
    pub index: usize,
    /// Stable, filename-safe id, e.g. `2000lux-150hz-20pct`.
    pub id: String,
    /// Ambient illuminance in lux.
    pub light_lux: f64,
    /// PWM frequency in Hz.
    pub frequency_hz: f64,
    /// Duty cycle in (0, 1].
    pub duty: f64,
    /// Seed for this case's random numbers, from the plan seed and the id,
    /// so results never depend on which thread ran the case.
    pub seed: u64,
}

/// Expands the plan's grids into cases. A captured plan's cases are its
/// `[[case]]` entries; unknown conditions are 0 there (never a valid value).
pub fn expand_cases(plan: &Plan) -> Vec<TestCase> {
    let mut cases = Vec::new();
    if plan.dut.backend == super::BackendKind::Captured
        && let Some(cap) = &plan.capture
    {
        for c in &cap.cases {
            cases.push(TestCase {
                index: cases.len(),
                seed: case_seed(plan.seed, &c.id),
                id: c.id.clone(),
                light_lux: c.light_lux.unwrap_or(0.0),
                frequency_hz: c.frequency_hz.unwrap_or(0.0),
                duty: c.duty.unwrap_or(0.0),
            });
        }
        return cases;
    }
    for &lux in &plan.light_levels_lux {
        for &f in &plan.frequencies_hz {
            for &d in &plan.duty_cycles {
                let id = condition_id(lux, f, d);
                cases.push(TestCase {
                    index: cases.len(),
                    seed: case_seed(plan.seed, &id),
                    id,
                    light_lux: lux,
                    frequency_hz: f,
                    duty: d,
                });
            }
        }
    }
    cases
}

/// Case id of a condition, e.g. `2000lux-150hz-20pct`.
pub fn condition_id(lux: f64, frequency_hz: f64, duty: f64) -> String {
    format!(
        "{}lux-{}hz-{}pct",
        number(lux),
        number(frequency_hz),
        number(duty * 100.0)
    )
}

/// A short decimal for ids: at most 6 decimals, no trailing zeros.
fn number(x: f64) -> String {
    let s = format!("{:.6}", x);
    let s = s.trim_end_matches('0').trim_end_matches('.');
    s.to_string()
}

/// SplitMix64 of the plan seed mixed with the FNV-1a hash of the case id:
/// stable across platforms and Rust versions (unlike `DefaultHasher`).
pub fn case_seed(plan_seed: u64, case_id: &str) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in case_id.bytes() {
        h ^= b as u64;
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    let mut z = plan_seed ^ h;
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

impl super::SegmentFrames {
    /// Segment of frame `k`.
    pub fn segment(&self, k: u64) -> crate::trace::Segment {
        use crate::trace::Segment;
        match k {
            _ if k < self.on => Segment::On,
            _ if k < self.on + self.off => Segment::Off,
            _ => Segment::Pwm,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_in_ids_are_short_and_exact() {
        assert_eq!(number(2000.0), "2000");
        assert_eq!(number(62.5), "62.5");
        assert_eq!(number(0.05 * 100.0), "5");
        assert_eq!(number(0.125 * 100.0), "12.5");
    }

    #[test]
    fn case_seed_depends_on_plan_seed_and_id() {
        assert_ne!(case_seed(1, "a"), case_seed(2, "a"));
        assert_ne!(case_seed(1, "a"), case_seed(1, "b"));
        assert_eq!(case_seed(7, "x"), case_seed(7, "x"));
    }
}
