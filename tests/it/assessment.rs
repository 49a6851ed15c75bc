//! The assessment (issue 32): drift fragilities, the indicators' verdicts
//! and the rules that combine them (`quaketwin::assessment`).

use quaketwin::assessment::fragility::*;
use quaketwin::assessment::indicators::*;
use quaketwin::assessment::*;
use quaketwin::stats::standard_normal_cdf;

fn ind(kind: IndicatorKind, state: Option<DamageState>) -> Indicator {
    Indicator {
        kind,
        value: Some(0.0),
        subject: String::new(),
        state,
        verdict: state
            .map(|s| s.name().to_string())
            .unwrap_or("not rated: absent".into()),
        provisional: false,
    }
}

#[test]
fn agreement_gives_the_colour_and_a_lone_indicator_gives_inspect() {
    use DamageState::*;
    use IndicatorKind::*;
    let all_none = combine(&[ind(Drift, Some(None)), ind(Frequency, Some(None))]);
    assert_eq!(all_none.colour, Some(Colour::Green));
    let corroborated = combine(&[
        ind(Drift, Some(Extensive)),
        ind(Frequency, Some(Complete)),
        ind(ResidualDrift, Some(Extensive)),
    ]);
    assert_eq!(corroborated.colour, Some(Colour::Red));
    assert!(corroborated.confidence.starts_with("corroborated"));
    let lone = combine(&[ind(Drift, Some(Extensive)), ind(Frequency, Some(None))]);
    assert_eq!(lone.colour, Some(Colour::Yellow));
    assert_eq!(lone.confidence, "single indicator");
    assert!(lone.drivers[0].starts_with("peak drift"));
    let partly = combine(&[ind(Drift, Some(Extensive)), ind(Frequency, Some(Moderate))]);
    assert_eq!(partly.colour, Some(Colour::Orange));
    let beyond = combine(&[
        ind(Drift, Some(Extensive)),
        ind(Frequency, Some(Complete)),
        ind(Hysteresis, Some(None)),
    ]);
    assert_eq!(beyond.colour, Some(Colour::Red));
    assert!(
        beyond.confidence.contains("alone reaches complete"),
        "{}",
        beyond.confidence
    );
    let only = combine(&[ind(Drift, Some(Complete)), ind(Frequency, Option::None)]);
    assert_eq!(only.colour, Some(Colour::Yellow));
    assert_eq!(only.confidence, "only one indicator rated");
    let only_none = combine(&[ind(Drift, Some(None)), ind(Frequency, Option::None)]);
    assert_eq!(only_none.colour, Some(Colour::Green));
    let nothing = combine(&[ind(Drift, Option::None), ind(Frequency, Option::None)]);
    assert_eq!(nothing.colour, Option::None);
    assert!(nothing.reason.unwrap().contains("peak drift: absent"));
}

fn row(kind: &str, ratio: f64, height: &str, residual: Option<(f64, &str)>) -> DriftEvidence {
    DriftEvidence {
        direction: "X".into(),
        lower_level: 0,
        upper_level: 2,
        kind: kind.into(),
        peak_ratio: ratio,
        height_source: height.into(),
        residual_ratio: residual.map(|r| r.0),
        residual_status: residual.map(|r| r.1.to_string()),
    }
}

#[test]
fn drift_is_rated_through_the_fragility_and_never_from_an_estimate() {
    let choice = FragilityChoice {
        fragility: DriftFragility::of("C1", DesignLevel::Moderate),
        default_used: true,
        why_none: None,
    };
    let (i, p) = drift_indicator(
        &[
            row("estimate", 0.05, "stated", None),
            row("segment", 0.015, "assumed", None),
        ],
        &choice,
    );
    assert_eq!(i.state, Some(DamageState::Moderate));
    assert!(i.provisional);
    assert!((p.unwrap().iter().sum::<f64>() - 1.0).abs() < 1e-9);
    let (i, p) = drift_indicator(&[row("estimate", 0.05, "stated", None)], &choice);
    assert_eq!(i.state, None);
    assert!(p.is_none());
    let bridge = FragilityChoice {
        fragility: None,
        default_used: false,
        why_none: Some("a bridge".into()),
    };
    assert!(
        drift_indicator(&[row("measured", 0.02, "stated", None)], &bridge)
            .0
            .verdict
            .contains("a bridge")
    );
}

#[test]
fn only_a_resolved_residual_is_rated() {
    let i = residual_indicator(&[row("measured", 0.01, "stated", Some((0.006, "unresolved")))]);
    assert_eq!(i.state, None);
    let i = residual_indicator(&[row("measured", 0.01, "stated", Some((-0.006, "resolved")))]);
    assert_eq!(i.state, Some(DamageState::Moderate));
}

#[test]
fn a_lasting_softening_keeps_the_f_test_from_saying_linear() {
    let e = FrequencyEvidence {
        direction: "X".into(),
        channels: "roof / base".into(),
        before_hz: Some(1.0),
        before_source: "pre-event windows".into(),
        min_during_hz: Some(0.7),
        after_hz: Some(0.78),
        scatter: 0.01,
        why_missing: None,
    };
    let f = frequency_indicator(&[e.clone()]);
    assert_eq!(f.state, Some(DamageState::Extensive));
    let quiet = [HysteresisEvidence {
        direction: "X".into(),
        outcome: HysteresisOutcome::NoSignificantHysteresis {
            reason: "p = 0.3".into(),
        },
    }];
    assert_eq!(hysteresis_indicator(&quiet, &f).state, None);
    let steady = frequency_indicator(&[FrequencyEvidence {
        after_hz: Some(0.99),
        ..e
    }]);
    assert_eq!(steady.state, Some(DamageState::None));
    assert_eq!(
        hysteresis_indicator(&quiet, &steady).state,
        Some(DamageState::None)
    );
}

#[test]
fn probabilities_sum_to_one_and_follow_the_medians() {
    let f = DriftFragility::of("C1", DesignLevel::Moderate).unwrap();
    for d in [0.0, 0.001, 0.005, 0.009, 0.02, 0.06, 0.2] {
        let p = f.probabilities(d).unwrap();
        assert!((p.iter().sum::<f64>() - 1.0).abs() < 1e-9, "{d}: {p:?}");
        assert!(p.iter().all(|&v| v >= -1e-12), "{d}: {p:?}");
    }
    // At a median, half the buildings have reached that state.
    let p = f.probabilities(0.009).unwrap();
    assert!((p[2] + p[3] + p[4] - 0.5).abs() < 1e-6, "{p:?}");
    assert_eq!(f.most_likely(0.0005), Some(DamageState::None));
    assert_eq!(f.most_likely(0.015), Some(DamageState::Moderate));
    assert_eq!(f.most_likely(0.10), Some(DamageState::Complete));
    assert_eq!(f.probabilities(f64::NAN), None);
}

#[test]
fn every_type_has_ascending_medians_at_every_level() {
    for (code, _) in BUILDING_TYPES {
        for level in [
            DesignLevel::High,
            DesignLevel::Moderate,
            DesignLevel::Low,
            DesignLevel::Pre,
        ] {
            let f = DriftFragility::of(code, level).unwrap();
            assert!(f.medians.windows(2).all(|w| w[0] < w[1]), "{code}");
        }
    }
}

#[test]
fn types_are_read_with_their_height_suffix_dropped() {
    assert_eq!(read_type("c1m").code, Some("C1"));
    assert!(read_type("C1M").note.unwrap().contains("height class"));
    assert_eq!(read_type("URML").code, Some("URM"));
    assert_eq!(read_type("W1A").code, Some("W1"));
    assert_eq!(read_type("RM2").code, Some("RM2"));
    let bad = read_type("masonry tower");
    assert_eq!(bad.code, None);
    assert!(bad.note.unwrap().contains("not a HAZUS"));
    assert_eq!(DesignLevel::parse("Pre-code"), Some(DesignLevel::Pre));
    assert_eq!(DesignLevel::parse("medium"), None);
}

#[test]
fn normal_distribution_function_matches_tabled_values() {
    // Abramowitz & Stegun Table 26.1.
    for (x, p) in [
        (0.0, 0.5),
        (1.0, 0.841_344_746),
        (-1.96, 0.024_997_895),
        (3.0, 0.998_650_102),
    ] {
        assert!((standard_normal_cdf(x) - p).abs() < 1e-7, "{x}");
    }
}
