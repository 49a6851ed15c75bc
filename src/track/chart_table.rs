//! `control_chart/control_chart.parquet` of `quaketwin track`: one row per subgroup of
//! the compensation's control chart ([`crate::monitor::compensation`];
//! columns in docs/formats.md).

use crate::error::Result;
use crate::monitor::compensation::RunCompensation;
use crate::monitor::environment::Compensation;
use crate::sinks::parquet::TableBuilder;
use crate::sinks::provenance::Provenance;
use crate::vocab::tables::{control_chart as col, CONTROL_CHART};

/// The rows (none without a chart).
pub fn chart_batch(c: &RunCompensation) -> Result<arrow_array::RecordBatch> {
    let groups = match &c.chart {
        Some(_) => c.subgroups.as_slice(),
        None => &[],
    };
    let (threshold, dof) = c
        .chart
        .as_ref()
        .map_or((f64::NAN, 0), |ch| (ch.threshold, ch.dof as i32));
    TableBuilder::new(&CONTROL_CHART)
        .timestamp_ns(
            col::SUBGROUP_START.name,
            groups.iter().map(|g| g.start_ns).collect(),
        )
        .timestamp_ns(
            col::SUBGROUP_END.name,
            groups.iter().map(|g| g.end_ns).collect(),
        )
        .u32(
            col::WINDOWS.name,
            groups.iter().map(|g| (g.end - g.first) as u32).collect(),
        )
        .u32(
            col::CHARTED_WINDOWS.name,
            groups.iter().map(|g| g.charted as u32).collect(),
        )
        .bool(
            col::TRAINING.name,
            groups.iter().map(|g| g.training).collect(),
        )
        .str(
            col::MODEL.name,
            &groups.iter().map(|_| c.model.as_str()).collect::<Vec<_>>(),
        )
        .opt_f64(
            col::STATISTIC.name,
            groups.iter().map(|g| g.statistic).collect(),
        )
        .f64(col::THRESHOLD.name, vec![threshold; groups.len()])
        .opt_f64(
            col::P_VALUE.name,
            groups.iter().map(|g| g.p_value).collect(),
        )
        .i32(col::DOF.name, vec![dof; groups.len()])
        .opt_bool(
            col::OUT_OF_CONTROL.name,
            groups.iter().map(|g| g.out_of_control).collect(),
        )
        .bool(
            col::ALARM.name,
            (0..groups.len()).map(|i| c.alarm_from == Some(i)).collect(),
        )
        .build()
}

/// Table metadata: provenance, the fitted model (`quaketwin.compensation`)
/// and the warnings.
pub fn chart_metadata(c: &RunCompensation, provenance: &Provenance) -> Vec<(String, String)> {
    let mut m = provenance.metadata();
    let model = c.chart.as_ref().map(|ch| {
        let detail = match &ch.compensation {
            Compensation::Measured {
                mean_hz,
                fits,
                direction,
            } => serde_json::json!({
                "model": "measured",
                "source": c.source,
                "mean_hz": mean_hz,
                "intercepts": fits.iter().map(|f| f.0).collect::<Vec<_>>(),
                "slopes": fits.iter().map(|f| f.1).collect::<Vec<_>>(),
                "temperature_direction_removed": direction.is_some(),
            }),
            Compensation::Latent {
                mean_hz,
                retained,
                explained,
                ..
            } => serde_json::json!({
                "model": "latent",
                "mean_hz": mean_hz,
                "retained_directions": retained,
                "explained_variance": explained,
            }),
        };
        serde_json::json!({
            "compensation": detail,
            "training_windows": ch.training_windows,
            "subgroup_windows": ch.subgroup,
            "false_alarm_rate": ch.false_alarm_rate,
            "residual_band_half_width": c.residual_half_width,
        })
    });
    m.push((
        "quaketwin.compensation".into(),
        serde_json::json!({"chart": model, "warnings": c.warnings}).to_string(),
    ));
    m
}
