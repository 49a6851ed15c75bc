//! Parquet tables of the modal stage (schemas in docs/formats.md):
//! `stabilization.parquet` (every pole of every order), `modes.parquet`
//! (selected modes with statistics and shapes), `modal_spectrum.parquet`
//! (singular values of the PSD matrix, plotted beside the stabilisation
//! diagram), `frequency_shifts.parquet` (pre/post comparison).

use std::path::Path;

use super::parquet::{write_parquet, TableBuilder};
use crate::error::Result;
use crate::modal::{FrequencyShift, ModalResult, SpectralOverlay};

/// Metadata key holding the output channel ids (JSON list) the shapes refer to.
pub const OUTPUT_CHANNELS_KEY: &str = "quaketwin.output_channels";
/// Metadata key holding why fewer modes than expected were selected (JSON list of strings).
pub const WARNINGS_KEY: &str = "quaketwin.warnings";

fn meta(schema: &str, result: &ModalResult, settings_json: &str) -> Vec<(String, String)> {
    vec![
        ("quaketwin.schema".into(), schema.into()),
        (
            OUTPUT_CHANNELS_KEY.into(),
            serde_json::to_string(&result.output_ids).unwrap_or_default(),
        ),
        (
            "quaketwin.input_channels".into(),
            serde_json::to_string(&result.input_ids).unwrap_or_default(),
        ),
        ("quaketwin.method".into(), result.method.name().into()),
        ("quaketwin.block_rows".into(), result.block_rows.to_string()),
        ("quaketwin.settings".into(), settings_json.into()),
        (
            "quaketwin.history".into(),
            serde_json::to_string(&result.preprocessing).unwrap_or_default(),
        ),
        (
            "quaketwin.notes".into(),
            serde_json::to_string(&result.notes).unwrap_or_default(),
        ),
        (
            WARNINGS_KEY.into(),
            serde_json::to_string(&result.warnings).unwrap_or_default(),
        ),
        (
            "quaketwin.output_directions".into(),
            serde_json::to_string(&result.output_directions).unwrap_or_default(),
        ),
        (
            "quaketwin.band_hz".into(),
            serde_json::to_string(&result.band_hz).unwrap_or_default(),
        ),
        ("quaketwin.decimation".into(), result.decimation.to_string()),
        (
            "quaketwin.rejected_columns".into(),
            serde_json::Value::Array(
                result
                    .rejected
                    .iter()
                    .map(|c| {
                        serde_json::json!({
                            "frequency_hz": c.frequency_hz,
                            "damping_ratio": c.damping_ratio,
                            "poles": c.poles,
                            "order_min": c.order_min,
                            "order_max": c.order_max,
                            "reason": c.reason,
                        })
                    })
                    .collect(),
            )
            .to_string(),
        ),
    ]
}

pub fn write_stabilization(path: &Path, r: &ModalResult, settings_json: &str) -> Result<()> {
    let p = &r.poles;
    let batch = TableBuilder::new()
        .u32("order", p.iter().map(|x| x.order as u32).collect())
        .f64("frequency_hz", p.iter().map(|x| x.frequency_hz).collect())
        .f64("damping_ratio", p.iter().map(|x| x.damping_ratio).collect())
        .f64("mpc", p.iter().map(|x| x.mpc).collect())
        .f64("mpd_deg", p.iter().map(|x| x.mpd_deg).collect())
        .bool(
            "stable_frequency",
            p.iter().map(|x| x.stable_frequency).collect(),
        )
        .bool(
            "stable_damping",
            p.iter().map(|x| x.stable_damping).collect(),
        )
        .bool("stable_shape", p.iter().map(|x| x.stable_shape).collect())
        .bool("physical", p.iter().map(|x| x.physical).collect())
        .i32(
            "mode",
            p.iter()
                .map(|x| x.mode.map(|m| m as i32 + 1).unwrap_or(-1))
                .collect(),
        )
        .build()?;
    write_parquet(path, &[batch], &meta("stabilization", r, settings_json))
}

pub fn write_modes(path: &Path, r: &ModalResult, settings_json: &str) -> Result<()> {
    let m = &r.modes;
    let batch = TableBuilder::new()
        .u32("mode", (1..=m.len() as u32).collect())
        .f64("frequency_hz", m.iter().map(|x| x.frequency_hz).collect())
        .f64(
            "frequency_std_hz",
            m.iter().map(|x| x.frequency_std_hz).collect(),
        )
        .f64("damping_ratio", m.iter().map(|x| x.damping_ratio).collect())
        .f64("damping_std", m.iter().map(|x| x.damping_std).collect())
        .f64("mpc", m.iter().map(|x| x.mpc).collect())
        .f64("mpd_deg", m.iter().map(|x| x.mpd_deg).collect())
        .f64("mean_mac", m.iter().map(|x| x.mean_mac).collect())
        .u32(
            "pole_count",
            m.iter().map(|x| x.pole_count as u32).collect(),
        )
        .u32("order_min", m.iter().map(|x| x.order_min as u32).collect())
        .u32("order_max", m.iter().map(|x| x.order_max as u32).collect())
        .bool("manual", m.iter().map(|x| x.manual).collect())
        .str(
            "direction",
            &m.iter().map(|x| x.direction.as_str()).collect::<Vec<_>>(),
        )
        .list_f64(
            "shape_re",
            &m.iter()
                .map(|x| x.shape.iter().map(|c| c.re).collect())
                .collect::<Vec<_>>(),
        )
        .list_f64(
            "shape_im",
            &m.iter()
                .map(|x| x.shape.iter().map(|c| c.im).collect())
                .collect::<Vec<_>>(),
        )
        .list_f64(
            "shape_std",
            &m.iter().map(|x| x.shape_std.clone()).collect::<Vec<_>>(),
        )
        .build()?;
    write_parquet(path, &[batch], &meta("modes", r, settings_json))
}

/// Singular values of the factorisation and of the PSD matrix, long format.
pub fn write_spectrum(
    path: &Path,
    r: &ModalResult,
    overlay: Option<&SpectralOverlay>,
    settings_json: &str,
) -> Result<()> {
    let (mut kind, mut index, mut freq, mut value) = (vec![], vec![], vec![], vec![]);
    for (i, s) in r.singular_values.iter().enumerate() {
        kind.push("subspace");
        index.push(i as i32 + 1);
        freq.push(None);
        value.push(*s);
    }
    if let Some(o) = overlay {
        for (k, f) in o.frequencies_hz.iter().enumerate() {
            for (i, s) in o.singular_values.get(k).into_iter().flatten().enumerate() {
                kind.push("psd");
                index.push(i as i32 + 1);
                freq.push(Some(*f));
                value.push(*s);
            }
        }
    }
    let batch = TableBuilder::new()
        .str("kind", &kind)
        .i32("index", index)
        .opt_f64("frequency_hz", freq)
        .f64("value", value)
        .build()?;
    write_parquet(path, &[batch], &meta("modal_spectrum", r, settings_json))
}

pub fn write_shifts(
    path: &Path,
    shifts: &[FrequencyShift],
    reference_event: &str,
    this_event: &str,
) -> Result<()> {
    let s = shifts;
    let batch = TableBuilder::new()
        .u32(
            "reference_mode",
            s.iter().map(|x| x.reference_mode as u32 + 1).collect(),
        )
        .u32(
            "other_mode",
            s.iter().map(|x| x.other_mode as u32 + 1).collect(),
        )
        .f64(
            "frequency_reference_hz",
            s.iter().map(|x| x.frequency_reference_hz).collect(),
        )
        .f64(
            "frequency_other_hz",
            s.iter().map(|x| x.frequency_other_hz).collect(),
        )
        .f64(
            "relative_shift",
            s.iter().map(|x| x.relative_shift).collect(),
        )
        .f64("shift_in_std", s.iter().map(|x| x.shift_in_std).collect())
        .f64(
            "damping_reference",
            s.iter().map(|x| x.damping_reference).collect(),
        )
        .f64("damping_other", s.iter().map(|x| x.damping_other).collect())
        .f64("mac", s.iter().map(|x| x.mac).collect())
        .build()?;
    write_parquet(
        path,
        &[batch],
        &[
            ("quaketwin.schema".into(), "frequency_shifts".into()),
            ("quaketwin.reference_event".into(), reference_event.into()),
            ("quaketwin.event".into(), this_event.into()),
        ],
    )
}

/// Reads the modes of a `modes.parquet` back (for pre/post comparison),
/// with the output channel ids of its metadata.
pub fn read_modes(path: &Path) -> Result<(Vec<crate::modal::Mode>, Vec<String>)> {
    use arrow_array::{Array, BooleanArray, Float64Array, ListArray, UInt32Array};

    use super::parquet::ReadTable;
    use crate::error::Error;
    let table = ReadTable::open(path)?;
    let loc = || table.location();
    let channels: Vec<String> = table
        .metadata(OUTPUT_CHANNELS_KEY)
        .and_then(|v| serde_json::from_str(v).ok())
        .ok_or_else(|| {
            Error::input(
                loc(),
                format!("metadata {OUTPUT_CHANNELS_KEY} missing: not a quaketwin modes.parquet"),
            )
        })?;
    let mut modes = Vec::new();
    for b in &table.batches {
        let f = |n: &str| table.column::<Float64Array>(b, n);
        let u = |n: &str| table.column::<UInt32Array>(b, n);
        let l = |n: &str| table.column::<ListArray>(b, n);
        let (fr, fs, z, zs, mpc, mpd, mm) = (
            f("frequency_hz")?,
            f("frequency_std_hz")?,
            f("damping_ratio")?,
            f("damping_std")?,
            f("mpc")?,
            f("mpd_deg")?,
            f("mean_mac")?,
        );
        let (pc, omin, omax) = (u("pole_count")?, u("order_min")?, u("order_max")?);
        let manual = b
            .column_by_name("manual")
            .ok_or_else(|| Error::input(loc(), "column manual missing"))?
            .as_any()
            .downcast_ref::<BooleanArray>()
            .cloned();
        let (re, im, sd) = (l("shape_re")?, l("shape_im")?, l("shape_std")?);
        // Optional: files written before issue 13 have no direction column.
        let direction = b
            .column_by_name("direction")
            .and_then(|c| c.as_any().downcast_ref::<arrow_array::StringArray>())
            .cloned();
        let values = |a: &ListArray, i: usize| -> Vec<f64> {
            a.value(i)
                .as_any()
                .downcast_ref::<Float64Array>()
                .map(|v| v.values().to_vec())
                .unwrap_or_default()
        };
        for i in 0..b.num_rows() {
            let (r, m) = (values(&re, i), values(&im, i));
            if r.len() != channels.len() || m.len() != channels.len() {
                return Err(Error::input(
                    loc(),
                    format!(
                        "mode {} has a shape of {} entries for {} channels",
                        i + 1,
                        r.len(),
                        channels.len()
                    ),
                ));
            }
            modes.push(crate::modal::Mode {
                frequency_hz: fr.value(i),
                frequency_std_hz: fs.value(i),
                damping_ratio: z.value(i),
                damping_std: zs.value(i),
                shape: r
                    .iter()
                    .zip(&m)
                    .map(|(a, b)| faer::c64::new(*a, *b))
                    .collect(),
                shape_std: values(&sd, i),
                mpc: mpc.value(i),
                mpd_deg: mpd.value(i),
                mean_mac: mm.value(i),
                pole_count: pc.value(i) as usize,
                order_min: omin.value(i) as usize,
                order_max: omax.value(i) as usize,
                manual: manual.as_ref().map(|a| a.value(i)).unwrap_or(false),
                direction: direction
                    .as_ref()
                    .map(|a| a.value(i).to_string())
                    .unwrap_or_default(),
            });
        }
    }
    Ok((modes, channels))
}
