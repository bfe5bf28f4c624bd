//! The process exit code of every command, one distinct number per
//! meaning. Scripts and CI jobs branch on these numbers, so they are part
//! of the published contract beside results.json: a meaning keeps its
//! number, and a new meaning takes a new one (README, "Exit codes").

/// Why a command ended, as its process exit code ([`ExitCode::code`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ExitCode {
    /// Every judged case passed and at least one case was judged;
    /// `verify`: every hash and signature matched and every signer is
    /// trusted; `compare`: no regression.
    Pass,
    /// Some case failed, `--golden` found drift beyond tolerance,
    /// `compare` found a regression, or `verify` found a mismatch.
    Fail,
    /// Invalid plan, input or usage.
    Invalid,
    /// Internal or backend error.
    Internal,
    /// `plan`, `merge`: the run completed but no case was judged (every
    /// case informational).
    NotJudged,
    /// `compare`: the two runs are different tests, or share no case or
    /// no gated KPI.
    NotComparable,
    /// `verify` without `--trust`: intact, but nobody vouched for the
    /// signers.
    IdentityUnchecked,
    /// `linetime`, `bands`, `calibrate`: the input gives no confident
    /// estimate.
    NoConfidence,
    /// Stopped by this signal (SIGINT, SIGTERM).
    Signal(i32),
}

impl ExitCode {
    /// Every meaning but a signal, in the order of their numbers.
    pub const ALL: [ExitCode; 8] = [
        ExitCode::Pass,
        ExitCode::Fail,
        ExitCode::Invalid,
        ExitCode::Internal,
        ExitCode::NotJudged,
        ExitCode::NotComparable,
        ExitCode::IdentityUnchecked,
        ExitCode::NoConfidence,
    ];

    /// One line on what the number tells a script (the man pages' EXIT
    /// STATUS; the README's table says it at length).
    pub const fn meaning(self) -> &'static str {
        match self {
            ExitCode::Pass => {
                "every judged case passed and at least one was judged; verify: intact and every signer trusted; compare: no regression"
            }
            ExitCode::Fail => {
                "some case failed or drifted beyond the golden tolerance; compare: a KPI regressed; verify: a mismatch, an untrusted signer or an unsigned report"
            }
            ExitCode::Invalid => "invalid plan, input or usage",
            ExitCode::Internal => "internal or backend error",
            ExitCode::NotJudged => "plan, merge: the run completed but no case was judged",
            ExitCode::NotComparable => {
                "compare: the two runs are different tests, or share no case or gated KPI"
            }
            ExitCode::IdentityUnchecked => {
                "verify without --trust: intact, but the signers' identity was not checked"
            }
            ExitCode::NoConfidence => "linetime, bands, calibrate: no confident estimate",
            ExitCode::Signal(_) => {
                "stopped by a signal (128 + its number: 130 SIGINT, 143 SIGTERM)"
            }
        }
    }

    /// The number the process exits with: 0 to 7 by meaning; 128 + the
    /// signal number for [`ExitCode::Signal`], as a shell reports a
    /// process killed by it (130 for SIGINT, 143 for SIGTERM).
    pub const fn code(self) -> i32 {
        match self {
            ExitCode::Pass => 0,
            ExitCode::Fail => 1,
            ExitCode::Invalid => 2,
            ExitCode::Internal => 3,
            ExitCode::NotJudged => 4,
            ExitCode::NotComparable => 5,
            ExitCode::IdentityUnchecked => 6,
            ExitCode::NoConfidence => 7,
            ExitCode::Signal(signal) => 128 + signal,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::ExitCode::*;

    #[test]
    fn every_meaning_has_its_own_number() {
        let all = [
            Pass,
            Fail,
            Invalid,
            Internal,
            NotJudged,
            NotComparable,
            IdentityUnchecked,
            NoConfidence,
            Signal(2),
            Signal(15),
        ];
        let mut codes: Vec<i32> = all.iter().map(|c| c.code()).collect();
        assert_eq!(&codes[8..], [130, 143]);
        codes.sort_unstable();
        codes.dedup();
        assert_eq!(codes.len(), all.len());
    }
}
