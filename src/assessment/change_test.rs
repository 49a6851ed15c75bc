//! The change-test indicator: the subspace χ² test of the run's record
//! against the reference run's (`modal::change_test`, docs/statistics.md
//! Eqs. C1–C8), as the `modal` stage wrote it in
//! `change_test/change_test.parquet`.  I/O free.
//!
//! A detected change says the structure's dynamics differ from the
//! reference state's, not how much damage that is: its verdict is at most
//! **slight** (docs/assessment.md, "The subspace change test"), so it can
//! corroborate another indicator's slight damage (YELLOW) or, alone, ask
//! for an inspection (YELLOW) — never by itself an ORANGE or a RED.

use super::{DamageState, Indicator, IndicatorKind};

/// What the `modal` stage's test against the reference gave.
#[derive(Debug, Clone, PartialEq)]
pub enum ChangeTestEvidence {
    /// The test was made (Eq. C6).
    Tested {
        statistic: f64,
        threshold: f64,
        p_value: f64,
        false_alarm_rate: f64,
        /// statistic > threshold.
        changed: bool,
        /// The reference mode with the largest share of the statistic
        /// (Eq. C8): frequency (Hz) and share; none when no mode was shared.
        leading_mode: Option<(f64, f64)>,
    },
    /// A reference was given but no test could be made (the table's note).
    NotTested { reason: String },
}

/// The indicator (value: statistic / threshold, > 1 when a change is
/// detected): `changed` → slight ("a change of the dynamics: inspect"),
/// else none; not rated when no test could be made.
pub fn change_test_indicator(e: &ChangeTestEvidence) -> Indicator {
    let subject = "record against the reference run".to_string();
    match e {
        ChangeTestEvidence::NotTested { reason } => Indicator::not_rated(
            IndicatorKind::ChangeTest,
            None,
            subject,
            format!("no change test could be made: {reason}"),
        ),
        ChangeTestEvidence::Tested {
            statistic,
            threshold,
            p_value,
            false_alarm_rate,
            changed,
            leading_mode,
        } => {
            let ratio = statistic / threshold;
            let mode = leading_mode
                .map(|(f, share)| {
                    format!("; the largest share, {share:.1}, is the mode at {f:.3} Hz's (Eq. C8)")
                })
                .unwrap_or_default();
            let verdict = if *changed {
                format!(
                    "change detected: χ² {statistic:.1} > threshold {threshold:.1} at a false-alarm rate of {false_alarm_rate} (p = {p_value:.2e}){mode} — the dynamics differ from the reference state's: inspect"
                )
            } else {
                format!(
                    "none: χ² {statistic:.1} ≤ threshold {threshold:.1} at a false-alarm rate of {false_alarm_rate} (p = {p_value:.2})"
                )
            };
            Indicator {
                kind: IndicatorKind::ChangeTest,
                value: ratio.is_finite().then_some(ratio),
                subject,
                state: Some(if *changed {
                    DamageState::Slight
                } else {
                    DamageState::None
                }),
                verdict,
                provisional: false,
            }
        }
    }
}
