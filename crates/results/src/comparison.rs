//! Comparing two runs case by case: the one engine behind
//! `plan --golden` (a run against a stored results.json, within
//! tolerances) and `compare` (two recorded runs, through the noise-aware
//! gate). Each side adapts its own cases to [`Cases`]; the engine pairs
//! them by id, names the cases only one side holds, finds the verdict
//! flips, and says whether a metric's change is beyond its
//! [`Tolerance`]. What a tolerance is made of (a fixed value per metric,
//! or a floor and a multiple of the run-to-run noise) stays with each
//! side, since that is where the two differ.

/// One side of a comparison: its cases in the order they are reported.
/// A side is walked, never held whole, so that a run whose cases are
/// spilled to disk stays so.
pub trait Cases {
    /// A case as this side holds it.
    type Case;
    /// Calls `f` with every case and its id, in this side's order.
    fn each(&self, f: &mut dyn FnMut(&str, &Self::Case));
    /// The case's verdict, as results.json spells it.
    fn verdict<'c>(&self, case: &'c Self::Case) -> &'c str;
}

/// A side whose cases are also found by id: the side that does not lead.
pub trait Lookup: Cases {
    /// The case of this id, if this side holds it.
    fn get(&self, id: &str) -> Option<&Self::Case>;
}

/// Which side leads, the baseline A or the run B judged against it: the
/// pairing follows the leading side's order, and a flip goes from A's
/// verdict to B's.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Lead {
    /// Side A (the baseline) leads.
    A,
    /// Side B (the run judged against it) leads.
    B,
}

/// A case id as the pairing found it.
#[derive(Debug)]
pub enum Pair<'s, CL, CO> {
    /// In both runs under the same conditions: compared.
    Matched {
        /// Case id.
        id: &'s str,
        /// The case in the leading side.
        lead: &'s CL,
        /// The case in the other side.
        other: &'s CO,
    },
    /// In both runs, but under other conditions: not compared.
    Differs(&'s str),
    /// Only in the leading side.
    OnlyLead(&'s str),
    /// Only in the other side.
    OnlyOther(&'s str),
}

/// A case whose verdict differs between the runs.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct VerdictFlip {
    /// Case id.
    pub case: String,
    /// Its verdict in A.
    pub from: String,
    /// Its verdict in B.
    pub to: String,
}

/// Pairs the cases of `lead` and `other` by id: hands `on` every case of
/// the leading side in its order, then every case only the other side
/// holds, in its order; returns the verdict flips of the matched cases,
/// in the same order. `same_conditions` decides whether a case both runs
/// hold may be compared (a case run under other conditions is not the
/// same test); `lead_is` says which side is A.
pub fn pair<L: Cases, O: Lookup>(
    lead: &L,
    other: &O,
    lead_is: Lead,
    same_conditions: impl Fn(&L::Case, &O::Case) -> bool,
    mut on: impl FnMut(Pair<'_, L::Case, O::Case>),
) -> Vec<VerdictFlip> {
    let mut flips = Vec::new();
    let mut seen = std::collections::HashSet::new();
    lead.each(&mut |id, cl| {
        seen.insert(id.to_string());
        let Some(co) = other.get(id) else {
            return on(Pair::OnlyLead(id));
        };
        if !same_conditions(cl, co) {
            return on(Pair::Differs(id));
        }
        let (vl, vo) = (lead.verdict(cl), other.verdict(co));
        if vl != vo {
            let (from, to) = match lead_is {
                Lead::A => (vl, vo),
                Lead::B => (vo, vl),
            };
            flips.push(VerdictFlip {
                case: id.to_string(),
                from: from.to_string(),
                to: to.to_string(),
            });
        }
        on(Pair::Matched {
            id,
            lead: cl,
            other: co,
        });
    });
    other.each(&mut |id, _| {
        if !seen.contains(id) {
            on(Pair::OnlyOther(id));
        }
    });
    flips
}

/// Which way of a metric's change counts against the run judged.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Direction {
    /// Any change, up or down (drift from a golden run).
    Either,
    /// A rise is worse (the metric's check is `<=`).
    Rise,
    /// A fall is worse (the metric's check is `>=`).
    Fall,
}

impl Direction {
    /// The direction of a check: `+1` a rise is worse, `-1` a fall, 0 no
    /// check (then any change).
    pub fn of_sign(worse: i8) -> Direction {
        match worse.signum() {
            1 => Direction::Rise,
            -1 => Direction::Fall,
            _ => Direction::Either,
        }
    }

    /// The change from `a` to `b` that counts: its size for
    /// [`Direction::Either`], else signed, positive towards worse.
    pub fn change(self, a: f64, b: f64) -> f64 {
        match self {
            Direction::Either => (b - a).abs(),
            Direction::Rise => b - a,
            Direction::Fall => -(b - a),
        }
    }
}

/// How far a metric may move before its change counts: beyond both a
/// floor (the smallest change that matters) and the noise (how far two
/// runs of the same test differ). A golden tolerance is a floor alone.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tolerance {
    /// The smallest change that counts.
    pub floor: f64,
    /// The change the run-to-run noise explains.
    pub noise: f64,
}

impl Tolerance {
    /// A fixed tolerance: any change beyond `floor` counts.
    pub fn fixed(floor: f64) -> Tolerance {
        Tolerance {
            floor,
            noise: f64::NEG_INFINITY,
        }
    }

    /// Whether the finite values `a` (baseline) and `b` differ beyond
    /// this tolerance in `direction`.
    pub fn exceeded(&self, direction: Direction, a: f64, b: f64) -> bool {
        let change = direction.change(a, b);
        change > self.floor && change > self.noise
    }
}

/// `b - a`, when both are defined and finite.
pub fn delta(a: Option<f64>, b: Option<f64>) -> Option<f64> {
    Some(b? - a?).filter(|d| d.is_finite())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Cases as (id, verdict, condition), in order.
    struct Run(Vec<(&'static str, &'static str, u32)>);
    type Case = (&'static str, &'static str, u32);

    impl Cases for Run {
        type Case = Case;
        fn each(&self, f: &mut dyn FnMut(&str, &Case)) {
            self.0.iter().for_each(|c| f(c.0, c));
        }
        fn verdict<'c>(&self, case: &'c Case) -> &'c str {
            case.1
        }
    }

    impl Lookup for Run {
        fn get(&self, id: &str) -> Option<&Case> {
            self.0.iter().find(|c| c.0 == id)
        }
    }

    fn names(lead: &Run, other: &Run, lead_is: Lead) -> (Vec<String>, Vec<VerdictFlip>) {
        let mut names = Vec::new();
        let flips = pair(
            lead,
            other,
            lead_is,
            |x, y| x.2 == y.2,
            |p| {
                names.push(match p {
                    Pair::Matched { id, .. } => format!("={id}"),
                    Pair::Differs(id) => format!("~{id}"),
                    Pair::OnlyLead(id) => format!("l{id}"),
                    Pair::OnlyOther(id) => format!("o{id}"),
                })
            },
        );
        (names, flips)
    }

    #[test]
    fn pairing_follows_the_leading_side_then_the_other_sides_own_cases() {
        let a = Run(vec![
            ("1", "pass", 0),
            ("2", "pass", 0),
            ("3", "fail", 0),
            ("4", "pass", 0),
        ]);
        let b = Run(vec![
            ("5", "pass", 0),
            ("3", "pass", 1),
            ("2", "fail", 0),
            ("1", "pass", 0),
        ]);
        let (by_a, flips) = names(&a, &b, Lead::A);
        assert_eq!(by_a, ["=1", "=2", "~3", "l4", "o5"]);
        // Case 3 flips too, but under other conditions it is no flip.
        let flip = VerdictFlip {
            case: "2".into(),
            from: "pass".into(),
            to: "fail".into(),
        };
        assert_eq!(flips, std::slice::from_ref(&flip));
        let (by_b, flips) = names(&b, &a, Lead::B);
        assert_eq!(by_b, ["l5", "~3", "=2", "=1", "o4"]);
        // A's verdict first, whichever side leads.
        assert_eq!(flips, [flip]);
    }

    #[test]
    fn a_change_counts_beyond_both_the_floor_and_the_noise_in_its_direction() {
        let t = Tolerance {
            floor: 0.1,
            noise: 0.5,
        };
        assert!(t.exceeded(Direction::Rise, 1.0, 1.6));
        assert!(!t.exceeded(Direction::Rise, 1.0, 1.4));
        assert!(!t.exceeded(Direction::Fall, 1.0, 1.6));
        assert!(t.exceeded(Direction::Fall, 1.6, 1.0));
        assert!(t.exceeded(Direction::Either, 1.6, 1.0));
        let fixed = Tolerance::fixed(0.01);
        assert!(!fixed.exceeded(Direction::Either, 0.5, 0.51 - 1e-12));
        assert!(fixed.exceeded(Direction::Either, 0.5, 0.52));
        assert_eq!(Direction::of_sign(0), Direction::Either);
    }

    #[test]
    fn delta_needs_two_finite_values() {
        assert_eq!(delta(Some(1.0), Some(3.0)), Some(2.0));
        assert_eq!(delta(None, Some(3.0)), None);
        assert_eq!(delta(Some(1.0), Some(f64::INFINITY)), None);
    }
}
