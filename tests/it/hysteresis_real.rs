//! The Bouc-Wen stage on real records (read in place from ../shared/records;
//! nothing is copied). See each folder's PROVENANCE.md.

use quaketwin::conditioning::{ConditioningSettings, Detrend, Step};
use quaketwin::sinks::hysteresis_tables::DirectionOutcome;
use quaketwin::stages::hysteresis::{identify_event_at, DirectionSpec, HysteresisParams};

fn records(folder: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/records")
        .join(folder)
}

/// Mean removal only (no taper, no filter, no integration): the stage
/// integrates itself with `endpoint_ramp` drift control.
fn mean_removed(event: &quaketwin::vocab::Event) -> quaketwin::vocab::Event {
    let mut event = event.clone();
    let settings = ConditioningSettings {
        steps: vec![Step::Detrend(Detrend::Mean)],
        ..ConditioningSettings::minimal()
    };
    quaketwin::conditioning::condition_event(&mut event, &settings).unwrap();
    event
}

fn params(spec: DirectionSpec) -> HysteresisParams {
    HysteresisParams {
        velocity_drift: quaketwin::hysteresis::VelocityDrift::EndpointRamp,
        instantaneous: true,
        directions: Some(vec![spec]),
        ..HysteresisParams::default()
    }
}

fn describe(outcome: &DirectionOutcome) -> String {
    match outcome {
        DirectionOutcome::NotIdentifiable {
            direction, reason, ..
        } => {
            format!("{direction}: not identifiable: {reason}")
        }
        DirectionOutcome::Identified(id) => {
            let mut s = format!(
                "{}: identified; ω(0) = {:?} rad/s; final ι {:?}",
                id.direction,
                id.damage.omega.iter().map(|w| w[0]).collect::<Vec<_>>(),
                id.damage.final_iota()
            );
            for d in &id.dofs {
                s.push_str(&format!(
                    "\n  DoF {}: K0 {:?} N {:.3} β {:.3e} γ {:.3e} J_rel {:.3} share {:.3} F {:.3e} p {:.2e} stable {:?}",
                    d.dof,
                    d.k0,
                    d.exponent,
                    d.beta,
                    d.gamma,
                    d.cost_relative,
                    d.hysteretic_share,
                    d.significance.f_statistic,
                    d.significance.p_value,
                    d.stability.as_ref().map(|s| s.stable)
                ));
            }
            s
        }
    }
}

/// Mini shake table, flexible 3-storey steel model, "Northridge" run (120 Hz,
/// 101 s; Xsens DOT IMUs at ground and floors 1–3, Acc_X). A small linear
/// steel model: the nonlinear Bouc-Wen parameters must be reported as not
/// identifiable. Masses 0.142 kg per floor (the notebook's lumped mass).
#[test]
fn shake_table_linear_steel_model_is_not_identifiable() {
    let dir = records("mdof-mini-shake-table-flexible-3story");
    let event = quaketwin::event_folder::load(&dir).unwrap().event;
    let id_of = |folder: &str| -> String {
        event
            .records
            .iter()
            .find(|r| {
                r.channel.source.file.starts_with(folder)
                    && r.channel.source.file.contains("(Northridge)")
                    && r.channel.id.contains("Acc_X")
            })
            .unwrap_or_else(|| panic!("no Northridge Acc_X in {folder}"))
            .channel
            .id
            .clone()
    };
    let spec = DirectionSpec {
        direction: "X".into(),
        base: id_of("Ground Floor"),
        floors: vec![id_of("1st Floor"), id_of("2nd Floor"), id_of("3rd Floor")],
        masses_kg: Some(vec![0.142; 3]),
    };
    let (outcomes, _) =
        identify_event_at(&mean_removed(&event), Some(&dir), &params(spec)).unwrap();
    eprintln!("{}", describe(&outcomes[0]));
    assert!(
        matches!(&outcomes[0], DirectionOutcome::NotIdentifiable { reason, .. } if reason.contains("not identifiable")),
        "{}",
        describe(&outcomes[0])
    );
}

/// Painter St. Overpass, 1992 Petrolia (50 Hz, 60 s, CDMG V2 band-passed
/// 0.15–25 Hz by the agency): transverse (360°) deck at the centre bent
/// (station channel 7) against the base of the centre bent (channel 3), one
/// DoF, unit mass (ω and ι of one DoF do not depend on the mass scale).
#[test]
fn painter_street_petrolia_transverse() {
    let dir = records("csmip-ce89324-painterst-overpass/petrolia_25apr1992_ce89324p.zip");
    let event = quaketwin::event_folder::load(&dir).unwrap().event;
    let spec = DirectionSpec {
        direction: "transverse".into(),
        base: "89324.03".into(),
        floors: vec!["89324.07".into()],
        masses_kg: Some(vec![1.0]),
    };
    // Exploratory: what is asserted is that the stage reads the agency zip
    // in place and returns one reasoned outcome for the direction. Measured
    // (2026): not identifiable, F = 0.55 on (3, 23), p = 0.65 — a one-DoF
    // shear model of deck vs bent base does not capture this response
    // (abutment–soil interaction dominates the 1992 transverse response).
    let (outcomes, _) = identify_event_at(&mean_removed(&event), None, &params(spec)).unwrap();
    eprintln!("{}", describe(&outcomes[0]));
    assert_eq!(outcomes.len(), 1);
    assert_eq!(outcomes[0].direction(), "transverse");
    if let DirectionOutcome::NotIdentifiable { reason, .. } = &outcomes[0] {
        assert!(reason.contains("not identifiable"), "{reason}");
    }
}
