//! Parquet tables of the modal stage (schemas in docs/formats.md):
//! `stabilization/stabilization.parquet` (every pole of every order), `modes/modes.parquet`
//! (selected modes with statistics and shapes), `mode_shapes/mode_shapes.parquet` (the
//! same shapes in long form: one row per mode and channel),
//! `modal_spectrum/modal_spectrum.parquet`
//! (singular values of the PSD matrix, plotted beside the stabilisation
//! diagram), `frequency_shifts/frequency_shifts.parquet` (pre/post comparison).

use std::path::Path;

use super::parquet::{write_parquet, TableBuilder};
use super::provenance::Provenance;
use crate::error::Result;
use crate::modal::{Comparison, FrequencyShift, ModalResult, PairingSettings, SpectralOverlay};
use crate::vocab::tables::{
    frequency_shifts, modal_spectrum, mode_shapes, modes, stabilization, FREQUENCY_SHIFTS,
    MODAL_SPECTRUM, MODES, MODE_SHAPES, STABILIZATION,
};

/// Metadata key holding the output channel ids (JSON list) the shapes refer to.
pub const OUTPUT_CHANNELS_KEY: &str = "quaketwin.output_channels";
/// Metadata key holding why fewer modes than expected were selected (JSON list of strings).
pub const WARNINGS_KEY: &str = "quaketwin.warnings";

/// Metadata of every modal table (the schema name comes from the declaration).
/// The provenance comes first: the event's history followed by the modal
/// pre-processing (mean removal, decimation, band limits).
pub fn modal_metadata(
    result: &ModalResult,
    settings_json: &str,
    provenance: &Provenance,
) -> Vec<(String, String)> {
    let mut entries = provenance
        .clone()
        .then(result.preprocessing.iter().cloned())
        .metadata();
    entries.extend([
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
            "quaketwin.local_modes".into(),
            serde_json::Value::Array(
                result
                    .local_modes
                    .iter()
                    .map(|m| {
                        serde_json::json!({
                            "frequency_hz": m.frequency_hz,
                            "damping_ratio": m.damping_ratio,
                            "channel": m.channel,
                            "energy_share": m.energy_share,
                        })
                    })
                    .collect(),
            )
            .to_string(),
        ),
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
    ]);
    entries
}

pub fn write_stabilization(
    path: &Path,
    r: &ModalResult,
    settings_json: &str,
    provenance: &Provenance,
) -> Result<()> {
    let batch = stabilization_batch(r)?;
    write_parquet(
        path,
        &[batch],
        &modal_metadata(r, settings_json, provenance),
    )
}

/// The rows of `stabilization/stabilization.parquet` (every pole of every order).
pub fn stabilization_batch(r: &ModalResult) -> Result<arrow_array::RecordBatch> {
    let p = &r.poles;
    TableBuilder::new(&STABILIZATION)
        .u32(
            stabilization::ORDER,
            p.iter().map(|x| x.order as u32).collect(),
        )
        .f64(
            stabilization::FREQUENCY_HZ,
            p.iter().map(|x| x.frequency_hz).collect(),
        )
        .f64(
            stabilization::DAMPING_RATIO,
            p.iter().map(|x| x.damping_ratio).collect(),
        )
        .f64(stabilization::MPC, p.iter().map(|x| x.mpc).collect())
        .f64(
            stabilization::MPD_DEG,
            p.iter().map(|x| x.mpd_deg).collect(),
        )
        .bool(
            stabilization::STABLE_FREQUENCY,
            p.iter().map(|x| x.stable_frequency).collect(),
        )
        .bool(
            stabilization::STABLE_DAMPING,
            p.iter().map(|x| x.stable_damping).collect(),
        )
        .bool(
            stabilization::STABLE_SHAPE,
            p.iter().map(|x| x.stable_shape).collect(),
        )
        .bool(
            stabilization::PHYSICAL,
            p.iter().map(|x| x.physical).collect(),
        )
        .i32(
            stabilization::MODE,
            p.iter()
                .map(|x| x.mode.map(|m| m as i32 + 1).unwrap_or(-1))
                .collect(),
        )
        .build()
}

pub fn write_modes(
    path: &Path,
    r: &ModalResult,
    settings_json: &str,
    provenance: &Provenance,
) -> Result<()> {
    let batch = modes_batch(r)?;
    write_parquet(
        path,
        &[batch],
        &modal_metadata(r, settings_json, provenance),
    )
}

/// The rows of `modes/modes.parquet` (one per selected mode).
pub fn modes_batch(r: &ModalResult) -> Result<arrow_array::RecordBatch> {
    let m = &r.modes;
    TableBuilder::new(&MODES)
        .u32(modes::MODE, (1..=m.len() as u32).collect())
        .f64(
            modes::FREQUENCY_HZ,
            m.iter().map(|x| x.frequency_hz).collect(),
        )
        .f64(
            modes::FREQUENCY_STD_HZ,
            m.iter().map(|x| x.frequency_std_hz).collect(),
        )
        .f64(
            modes::DAMPING_RATIO,
            m.iter().map(|x| x.damping_ratio).collect(),
        )
        .f64(
            modes::DAMPING_STD,
            m.iter().map(|x| x.damping_std).collect(),
        )
        .opt_f64(
            modes::FREQUENCY_STD_DATA_HZ,
            m.iter()
                .map(|x| x.data_std.as_ref().map(|d| d.frequency_hz))
                .collect(),
        )
        .opt_f64(
            modes::DAMPING_STD_DATA,
            m.iter()
                .map(|x| x.data_std.as_ref().map(|d| d.damping))
                .collect(),
        )
        .opt_str(
            modes::UNCERTAINTY_BASIS,
            &m.iter()
                .map(|x| x.data_std.as_ref().map(|d| d.basis.name()))
                .collect::<Vec<_>>(),
        )
        .opt_u32(
            modes::UNCERTAINTY_BLOCKS,
            m.iter()
                .map(|x| x.data_std.as_ref().map(|d| d.blocks as u32))
                .collect(),
        )
        .opt_f64(
            modes::UNCERTAINTY_DOF,
            m.iter()
                .map(|x| x.data_std.as_ref().map(|d| d.dof))
                .collect(),
        )
        .f64(modes::MPC, m.iter().map(|x| x.mpc).collect())
        .f64(modes::MPD_DEG, m.iter().map(|x| x.mpd_deg).collect())
        .f64(modes::MEAN_MAC, m.iter().map(|x| x.mean_mac).collect())
        .u32(
            modes::POLE_COUNT,
            m.iter().map(|x| x.pole_count as u32).collect(),
        )
        .u32(
            modes::ORDER_MIN,
            m.iter().map(|x| x.order_min as u32).collect(),
        )
        .u32(
            modes::ORDER_MAX,
            m.iter().map(|x| x.order_max as u32).collect(),
        )
        .bool(modes::MANUAL, m.iter().map(|x| x.manual).collect())
        .str(
            modes::DIRECTION,
            &m.iter().map(|x| x.direction.as_str()).collect::<Vec<_>>(),
        )
        .list_f64(
            modes::SHAPE_RE,
            &m.iter()
                .map(|x| x.shape.iter().map(|c| c.re).collect())
                .collect::<Vec<_>>(),
        )
        .list_f64(
            modes::SHAPE_IM,
            &m.iter()
                .map(|x| x.shape.iter().map(|c| c.im).collect())
                .collect::<Vec<_>>(),
        )
        .list_f64(
            modes::SHAPE_STD,
            &m.iter().map(|x| x.shape_std.clone()).collect::<Vec<_>>(),
        )
        .build()
}

/// `mode_shapes/mode_shapes.parquet`: the shapes of `modes/modes.parquet` in long form, one
/// row per mode and output channel (in the order of
/// `quaketwin.output_channels`), so that a query needs no metadata to know
/// which channel a component belongs to.  `levels` gives each output
/// channel's level (same order as `r.output_ids`; `None` = unknown).
pub fn write_mode_shapes(
    path: &Path,
    r: &ModalResult,
    levels: &[Option<i32>],
    settings_json: &str,
    provenance: &Provenance,
) -> Result<()> {
    let batch = mode_shapes_batch(r, levels)?;
    write_parquet(
        path,
        &[batch],
        &modal_metadata(r, settings_json, provenance),
    )
}

/// The rows of `mode_shapes/mode_shapes.parquet`.
pub fn mode_shapes_batch(
    r: &ModalResult,
    levels: &[Option<i32>],
) -> Result<arrow_array::RecordBatch> {
    use mode_shapes as ms;
    let (mut mode, mut freq, mut channel, mut level, mut direction) =
        (vec![], vec![], vec![], vec![], vec![]);
    let (mut re, mut im, mut sd, mut sd_data) = (vec![], vec![], vec![], vec![]);
    for (m, x) in r.modes.iter().enumerate() {
        for (k, id) in r.output_ids.iter().enumerate() {
            let c = x
                .shape
                .get(k)
                .copied()
                .unwrap_or(faer::c64::new(f64::NAN, f64::NAN));
            mode.push(m as u32 + 1);
            freq.push(x.frequency_hz);
            channel.push(id.as_str());
            level.push(levels.get(k).copied().flatten());
            direction.push(r.output_directions.get(k).map_or("", String::as_str));
            re.push(c.re);
            im.push(c.im);
            sd.push(x.shape_std.get(k).copied().unwrap_or(f64::NAN));
            sd_data.push(
                x.data_std
                    .as_ref()
                    .and_then(|d| d.shape_modulus.get(k).copied()),
            );
        }
    }
    TableBuilder::new(&MODE_SHAPES)
        .u32(ms::MODE, mode)
        .f64(ms::FREQUENCY_HZ, freq)
        .str(ms::CHANNEL_ID, &channel)
        .opt_i32(ms::LEVEL, level)
        .str(ms::DIRECTION, &direction)
        .f64(ms::REAL, re)
        .f64(ms::IMAG, im)
        .f64(ms::MODULUS_STD, sd)
        .opt_f64(ms::MODULUS_STD_DATA, sd_data)
        .build()
}

/// Singular values of the factorisation and of the PSD matrix, long format.
pub fn write_spectrum(
    path: &Path,
    r: &ModalResult,
    overlay: Option<&SpectralOverlay>,
    settings_json: &str,
    provenance: &Provenance,
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
    let batch = TableBuilder::new(&MODAL_SPECTRUM)
        .str(modal_spectrum::KIND, &kind)
        .i32(modal_spectrum::INDEX, index)
        .opt_f64(modal_spectrum::FREQUENCY_HZ, freq)
        .f64(modal_spectrum::VALUE, value)
        .build()?;
    write_parquet(
        path,
        &[batch],
        &modal_metadata(r, settings_json, provenance),
    )
}

/// Writes the pre/post comparison against the reference modes at
/// `reference` (docs/formats.md): one row per pair; the shared channels,
/// the pairing settings and the notes (channels of one event only, modes
/// left unpaired and why) in the metadata.
pub fn write_shifts(
    path: &Path,
    c: &Comparison,
    pairing: &PairingSettings,
    reference: &Path,
    provenance: &Provenance,
) -> Result<()> {
    use frequency_shifts as fs;
    let s = &c.shifts;
    let f = |g: fn(&FrequencyShift) -> f64| s.iter().map(g).collect::<Vec<f64>>();
    let mode = |g: fn(&FrequencyShift) -> usize| s.iter().map(|x| g(x) as u32 + 1).collect();
    let batch = TableBuilder::new(&FREQUENCY_SHIFTS)
        .u32(fs::REFERENCE_MODE, mode(|x| x.reference_mode))
        .u32(fs::CURRENT_MODE, mode(|x| x.current_mode))
        .str(
            fs::DIRECTION_REFERENCE,
            &s.iter()
                .map(|x| x.direction_reference.as_str())
                .collect::<Vec<_>>(),
        )
        .str(
            fs::DIRECTION_CURRENT,
            &s.iter()
                .map(|x| x.direction_current.as_str())
                .collect::<Vec<_>>(),
        )
        .f64(fs::FREQUENCY_REFERENCE_HZ, f(|x| x.frequency_reference_hz))
        .f64(
            fs::FREQUENCY_REFERENCE_STD_HZ,
            f(|x| x.frequency_reference_std_hz),
        )
        .f64(fs::FREQUENCY_CURRENT_HZ, f(|x| x.frequency_current_hz))
        .f64(
            fs::FREQUENCY_CURRENT_STD_HZ,
            f(|x| x.frequency_current_std_hz),
        )
        .f64(fs::SHIFT_PERCENT, f(|x| x.shift_percent))
        .f64(fs::SHIFT_STD_PERCENT, f(|x| x.shift_std_percent))
        .opt_f64(
            fs::FREQUENCY_REFERENCE_STD_DATA_HZ,
            s.iter()
                .map(|x| x.frequency_reference_std_data_hz)
                .collect(),
        )
        .opt_f64(
            fs::FREQUENCY_CURRENT_STD_DATA_HZ,
            s.iter().map(|x| x.frequency_current_std_data_hz).collect(),
        )
        .str(
            fs::SHIFT_STD_BASIS,
            &s.iter().map(|x| x.shift_std_basis).collect::<Vec<_>>(),
        )
        .opt_f64(fs::SHIFT_DOF, s.iter().map(|x| x.shift_dof).collect())
        .opt_bool(fs::SIGNIFICANT, s.iter().map(|x| x.significant).collect())
        .f64(fs::DAMPING_REFERENCE, f(|x| x.damping_reference))
        .f64(fs::DAMPING_CURRENT, f(|x| x.damping_current))
        .opt_f64(fs::MAC, s.iter().map(|x| x.mac).collect())
        .u32(
            fs::SHARED_CHANNELS,
            vec![c.shared_channels.len() as u32; s.len()],
        )
        .str(fs::PAIRING, &vec![c.basis.name(); s.len()])
        .build()?;
    let mut meta = provenance.metadata();
    meta.extend([
        (
            "quaketwin.reference".into(),
            reference.display().to_string(),
        ),
        (
            "quaketwin.shared_channels".into(),
            serde_json::to_string(&c.shared_channels).unwrap_or_default(),
        ),
        (
            "quaketwin.pairing".into(),
            serde_json::json!({
                "basis": c.basis.name(),
                "min_mac": pairing.min_mac,
                "frequency_window": pairing.frequency_window,
                "frequency_std_floor": pairing.frequency_std_floor,
            })
            .to_string(),
        ),
        (
            "quaketwin.notes".into(),
            serde_json::to_string(&c.notes).unwrap_or_default(),
        ),
    ]);
    write_parquet(path, &[batch], &meta)
}

/// The `modes/modes.parquet` an earlier run left at `path`: the file itself, or
/// `path/modes/modes.parquet` when `path` is a run's output directory.  Usage
/// errors (the user named it) that name the path: missing, no modes table
/// in the directory, not a quaketwin modes table.
pub fn locate_modes(path: &Path) -> Result<std::path::PathBuf> {
    use crate::error::Error;
    let shown = path.display();
    let file = match std::fs::metadata(path) {
        Err(e) => {
            let message = format!(
                "{shown}: {e}: expected the output directory of an earlier run (holding {}) or a {} file",
                MODES.file, MODES.file
            );
            return Err(if e.kind() == std::io::ErrorKind::NotFound {
                Error::MissingPath {
                    path: path.to_path_buf(),
                    message,
                }
            } else {
                Error::usage(message)
            });
        }
        Ok(m) if m.is_dir() => {
            let f = MODES.locate(path);
            // Absent only: a FIFO or device there is refused below, by name.
            if std::fs::metadata(&f).is_err() {
                return Err(Error::usage(format!(
                    "{shown}: holds no {}: not the output directory of a run with a modal stage",
                    MODES.file
                )));
            }
            f
        }
        Ok(_) => path.to_path_buf(),
    };
    // A FIFO would block the read: refused first, saying what it is.
    crate::input_file::check_regular(&file).map_err(|e| Error::usage(e.to_string()))?;
    read_modes(&file).map_err(|e| {
        Error::usage(format!(
            "{}: not a quaketwin modes table: {e}",
            file.display()
        ))
    })?;
    Ok(file)
}

/// Reads the modes of a `modes/modes.parquet` back (for pre/post comparison),
/// with the output channel ids of its metadata.
pub fn read_modes(path: &Path) -> Result<(Vec<crate::modal::Mode>, Vec<String>)> {
    use arrow_array::{Array, BooleanArray, Float64Array, ListArray, UInt32Array};

    use super::parquet::ReadTable;
    use crate::error::Error;
    use crate::vocab::schema::ColumnSpec;
    let table = ReadTable::open(path)?;
    let loc = || table.location();
    // Files written before the schema-first sinks carry no schema name.
    match table.metadata(crate::vocab::schema::SCHEMA_KEY) {
        Some(name) if name != MODES.name => {
            return Err(Error::input(
                loc(),
                format!("a {name} table, not {}", MODES.file),
            ))
        }
        _ => {}
    }
    let channels: Vec<String> = table
        .metadata(OUTPUT_CHANNELS_KEY)
        .and_then(|v| serde_json::from_str(v).ok())
        .ok_or_else(|| {
            Error::input(
                loc(),
                format!(
                    "metadata {OUTPUT_CHANNELS_KEY} missing: not a quaketwin modes/modes.parquet"
                ),
            )
        })?;
    let mut out = Vec::new();
    for b in &table.batches {
        let f = |c: &ColumnSpec| table.declared::<Float64Array>(b, c);
        let u = |c: &ColumnSpec| table.declared::<UInt32Array>(b, c);
        let l = |c: &ColumnSpec| table.declared::<ListArray>(b, c);
        let (fr, fs, z, zs, mpc, mpd, mm) = (
            f(&modes::FREQUENCY_HZ)?,
            f(&modes::FREQUENCY_STD_HZ)?,
            f(&modes::DAMPING_RATIO)?,
            f(&modes::DAMPING_STD)?,
            f(&modes::MPC)?,
            f(&modes::MPD_DEG)?,
            f(&modes::MEAN_MAC)?,
        );
        let (pc, omin, omax) = (
            u(&modes::POLE_COUNT)?,
            u(&modes::ORDER_MIN)?,
            u(&modes::ORDER_MAX)?,
        );
        let manual = table.declared::<BooleanArray>(b, &modes::MANUAL)?;
        let (re, im, sd) = (
            l(&modes::SHAPE_RE)?,
            l(&modes::SHAPE_IM)?,
            l(&modes::SHAPE_STD)?,
        );
        // Optional: files written before issue 36 have no data-driven σ.
        let optional_f64 = |c: &ColumnSpec| {
            b.column_by_name(c.name)
                .and_then(|c| c.as_any().downcast_ref::<Float64Array>())
                .cloned()
        };
        let (fs_data, zs_data) = (
            optional_f64(&modes::FREQUENCY_STD_DATA_HZ),
            optional_f64(&modes::DAMPING_STD_DATA),
        );
        let blocks = b
            .column_by_name(modes::UNCERTAINTY_BLOCKS.name)
            .and_then(|c| c.as_any().downcast_ref::<UInt32Array>())
            .cloned();
        // Optional: files written before Eq. S8' have blocks − 1.
        let dof = optional_f64(&modes::UNCERTAINTY_DOF);
        // Optional: files written before Eq. S9 have no basis (all were valid_orders).
        let basis = b
            .column_by_name(modes::UNCERTAINTY_BASIS.name)
            .and_then(|c| c.as_any().downcast_ref::<arrow_array::StringArray>())
            .cloned();
        let valid = |a: &Option<Float64Array>, i: usize| {
            a.as_ref().filter(|a| a.is_valid(i)).map(|a| a.value(i))
        };
        // Optional: files written before issue 13 have no direction column.
        let direction = b
            .column_by_name(modes::DIRECTION.name)
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
            out.push(crate::modal::Mode {
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
                manual: manual.value(i),
                direction: direction
                    .as_ref()
                    .map(|a| a.value(i).to_string())
                    .unwrap_or_default(),
                // The shape's data-driven σ lives in mode_shapes/mode_shapes.parquet.
                data_std: valid(&fs_data, i).zip(valid(&zs_data, i)).map(|(f, z)| {
                    let blocks = blocks
                        .as_ref()
                        .filter(|a| a.is_valid(i))
                        .map_or(0, |a| a.value(i) as usize);
                    crate::modal::uncertainty::ModeStd {
                        frequency_hz: f,
                        damping: z,
                        shape_modulus: Vec::new(),
                        blocks,
                        dof: valid(&dof, i).unwrap_or(blocks as f64 - 1.0),
                        basis: basis
                            .as_ref()
                            .filter(|a| a.is_valid(i))
                            .and_then(|a| {
                                crate::modal::uncertainty::StdBasis::from_name(a.value(i))
                            })
                            .unwrap_or_default(),
                    }
                }),
            });
        }
    }
    Ok((out, channels))
}
