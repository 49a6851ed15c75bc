//! Issue 36 item 1: the data-driven σ of frequency, damping and shape
//! (`modal::uncertainty`).  CI tests: the analytical first-order
//! sensitivities against central finite differences along the columns of
//! T (SSI-COV and input–output), and the normalised errors of a few seeds
//! of the 5-storey building.  The coverage study over 100 seeds is
//! `#[ignore]`d (docs/statistics.md holds its table).

use crate::modal::{ambient_input_seeded, earthquake_input_with_noise, five_storey};
use quaketwin::modal::poles::poles_of_order;
use quaketwin::modal::ssi::{
    cholesky_lower, covariance_toeplitz, eigen_structure, thin_svd_subspace,
};
use quaketwin::modal::uncertainty::{
    finite_difference_pole, interval_factor, io_sensitivity, l32_perturbations, po_moesp_blocks,
    po_moesp_l32, ssi_cov_blocks, Sensitivity,
};
use quaketwin::modal::{identify, Method, ModalInput, ModalSettings, Mode};
use quaketwin::synth::BuildingModes;

/// Relative difference of two σ.
fn relative(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs().max(1e-300)
}

/// The poles of order `order` of a factorised matrix (ascending frequency).
fn poles_of(
    m: &faer::Mat<f64>,
    outputs: usize,
    p: usize,
    order: usize,
    dt: f64,
) -> Vec<quaketwin::modal::Pole> {
    let sub = thin_svd_subspace(m.as_ref(), outputs, p).unwrap();
    let (a, c) = sub.realise(order).unwrap();
    poles_of_order(order, eigen_structure(a.as_ref(), c.as_ref()).unwrap(), dt)
}

/// Compares, for every pole of `order` within 5 % of a true frequency, the
/// analytical σ_f, σ_ζ with those of central finite differences.  The
/// first-order sensitivity is the limit of the difference quotient; with
/// a step of 1e-4 of T's columns the quotient's own error is O(step²):
/// they agree to 1 % (measured: ≤ 0.1 %).
fn check_against_finite_differences(
    factorised: &dyn Fn(usize, f64) -> faer::Mat<f64>,
    analytical_deltas: &[faer::Mat<f64>],
    outputs: usize,
    p: usize,
    order: usize,
    dt: f64,
    truth: &BuildingModes,
) -> usize {
    let m0 = factorised(0, 0.0);
    let sub = thin_svd_subspace(m0.as_ref(), outputs, p).unwrap();
    let sensitivity = Sensitivity::new(&sub, analytical_deltas, order);
    let mut checked = 0;
    for pole in poles_of(&m0, outputs, p, order, dt) {
        if !truth
            .frequencies_hz
            .iter()
            .any(|f| (pole.frequency_hz / f - 1.0).abs() < 0.05)
        {
            continue;
        }
        let s = sensitivity
            .pole(order, pole.frequency_hz, pole.damping_ratio, dt)
            .unwrap();
        let (sf, sz) = s.std();
        let (df, dz) = finite_difference_pole(
            |t, eps| Ok(factorised(t, eps)),
            analytical_deltas.len(),
            outputs,
            p,
            order,
            (pole.frequency_hz, pole.damping_ratio),
            dt,
            1e-4,
        )
        .unwrap();
        let rss = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
        let (ff, fz) = (rss(&df), rss(&dz));
        eprintln!(
            "{:.3} Hz: σ_f analytical {sf:.3e} finite-difference {ff:.3e}; σ_ζ {sz:.3e} {fz:.3e}",
            pole.frequency_hz
        );
        assert!(
            relative(sf, ff) < 0.01 && relative(sz, fz) < 0.01,
            "{:.3} Hz: analytical σ_f {sf:.3e}, σ_ζ {sz:.3e} vs finite differences {ff:.3e}, {fz:.3e}",
            pole.frequency_hz
        );
        // Column by column, not only in sum.
        for (a, b) in s.d_frequency.iter().zip(&df) {
            assert!((a - b).abs() <= 0.02 * ff, "J_f T_t {a:.3e} vs {b:.3e}");
        }
        checked += 1;
    }
    checked
}

/// SSI-COV on 120 s of the ambient 5-storey record (5 outputs, p = 20,
/// order 10, 12 blocks): analytical = finite differences for the 5 modes.
#[test]
fn ssi_cov_sensitivity_matches_finite_differences() {
    let input = ambient_input_seeded(3);
    let outputs: Vec<&[f64]> = input.outputs.iter().map(|s| &s[..12_000]).collect();
    let refs: Vec<usize> = (0..5).collect();
    let p = 20;
    let h = covariance_toeplitz(&outputs, &refs, p);
    let (_, deltas) = ssi_cov_blocks(&outputs, &refs, p, 12);
    let factorised = |t: usize, eps: f64| {
        let mut m = h.clone();
        if eps != 0.0 {
            m += faer::Scale(eps) * &deltas[t];
        }
        m
    };
    let truth = five_storey().modes().unwrap();
    let checked =
        check_against_finite_differences(&factorised, &deltas, 5, p, 10, input.dt, &truth);
    assert!(checked >= 4, "only {checked} poles near the true modes");
}

/// Input–output (PO-MOESP) on the 40-s earthquake: the Cholesky
/// derivative and the SVD sensitivity together against finite
/// differences of the Gram matrix.
#[test]
fn io_sensitivity_matches_finite_differences() {
    let input = earthquake_input_with_noise(2, 30.0);
    // Decimated by 2 as the modal stage does (200 → 100 Hz), by taking
    // every other sample of the noisy signals: enough for the comparison.
    let down = |s: &Vec<f64>| s.iter().step_by(2).copied().collect::<Vec<f64>>();
    let outs: Vec<Vec<f64>> = input.outputs.iter().map(down).collect();
    let ins: Vec<Vec<f64>> = input.inputs.iter().map(down).collect();
    let dt = 2.0 * input.dt;
    let outputs: Vec<&[f64]> = outs.iter().map(Vec::as_slice).collect();
    let inputs: Vec<&[f64]> = ins.iter().map(Vec::as_slice).collect();
    let p = 10;
    let (gram, dg) = po_moesp_blocks(&outputs, &inputs, p, 10);
    let deltas = l32_perturbations(gram.as_ref(), &dg, 1, 5, p).unwrap();
    let factorised = |t: usize, eps: f64| {
        let mut g = gram.clone();
        if eps != 0.0 {
            g += faer::Scale(eps) * &dg[t];
        }
        po_moesp_l32(g.as_ref(), 1, 5, p).unwrap()
    };
    let truth = five_storey().modes().unwrap();
    let checked = check_against_finite_differences(&factorised, &deltas, 5, p, 10, dt, &truth);
    assert!(checked >= 4, "only {checked} poles near the true modes");
    // The fast form (never forming dG_t nor dL₃₂) against this dense one:
    // the same linear map, so equal to rounding (1e-8 of the total).
    let r = gram.nrows();
    let flat: Vec<f64> = (0..r * r).map(|k| gram[(k / r, k % r)]).collect();
    let big_l = cholesky_lower(&flat, r).unwrap();
    let m0 = factorised(0, 0.0);
    let sub = thin_svd_subspace(m0.as_ref(), 5, p).unwrap();
    let dense = Sensitivity::new(&sub, &deltas, 10);
    let fast = io_sensitivity(&sub, big_l.as_ref(), &outputs, &inputs, 10, 10).unwrap();
    let mut compared = 0;
    for pole in poles_of(&m0, 5, p, 10, dt) {
        let (Ok(a), Ok(b)) = (
            dense.pole(10, pole.frequency_hz, pole.damping_ratio, dt),
            fast.pole(10, pole.frequency_hz, pole.damping_ratio, dt),
        ) else {
            continue;
        };
        let (sf, sz) = a.std();
        for (x, y) in a.d_frequency.iter().zip(&b.d_frequency) {
            assert!(
                (x - y).abs() <= 1e-8 * sf,
                "fast J_f T_t {y:.6e} vs dense {x:.6e}"
            );
        }
        for (x, y) in a.d_damping.iter().zip(&b.d_damping) {
            assert!(
                (x - y).abs() <= 1e-8 * sz,
                "fast J_ζ T_t {y:.6e} vs dense {x:.6e}"
            );
        }
        compared += 1;
    }
    assert!(compared >= 5, "only {compared} poles compared");
}

/// Per true mode: the identified mode nearest in frequency (within 10 %).
/// Identifies `input` with the default settings of `method` and maps each
/// true mode's matched estimate (with its data σ) through `row`; `None` where
/// no mode or no σ.  The studies' one identification per seed.
fn per_true_mode<T>(
    truth: &BuildingModes,
    input: &ModalInput,
    method: Method,
    row: impl Fn(usize, &Mode, &quaketwin::modal::uncertainty::ModeStd) -> T,
) -> Vec<Option<T>> {
    let settings = ModalSettings {
        method,
        ..Default::default()
    };
    let result = identify(input, &settings).unwrap();
    matched(truth, &result.modes)
        .into_iter()
        .enumerate()
        .map(|(j, m)| {
            let m = m?;
            Some(row(j, m, m.data_std.as_ref()?))
        })
        .collect()
}

fn matched<'a>(truth: &BuildingModes, modes: &'a [Mode]) -> Vec<Option<&'a Mode>> {
    truth
        .frequencies_hz
        .iter()
        .map(|&f| {
            modes
                .iter()
                .filter(|m| (m.frequency_hz / f - 1.0).abs() < 0.1)
                .min_by(|a, b| {
                    (a.frequency_hz - f)
                        .abs()
                        .total_cmp(&(b.frequency_hz - f).abs())
                })
        })
        .collect()
}

/// Normalised errors (f̂ − f)/σ_f and (ζ̂ − ζ)/σ_ζ of one identification,
/// per true mode, with the factor k of the 95 % interval θ̂ ± k σ
/// (`uncertainty::interval_factor` of the σ's blocks; None: missed or no σ).
fn normalised_errors(
    truth: &BuildingModes,
    input: &ModalInput,
    method: Method,
) -> Vec<Option<(f64, f64, f64, bool)>> {
    per_true_mode(truth, input, method, |j, m, d| {
        (
            (m.frequency_hz - truth.frequencies_hz[j]) / d.frequency_hz,
            (m.damping_ratio - truth.damping_ratios[j]) / d.damping,
            interval_factor(d.dof),
            d.basis == quaketwin::modal::uncertainty::StdBasis::Discrepancy,
        )
    })
}

/// CI version of the coverage study: three seeds of the 600-s ambient
/// record (SSI-COV), every mode found with a σ, and the normalised
/// frequency errors of the 15 estimates have a root mean square in
/// [0.4, 2.0] (1 for a correct σ; with 15 values the 95 % range of an
/// exact σ is about 0.65–1.3).  Catches a σ wrong by a factor of 2.
#[test]
fn ambient_normalised_errors_have_a_sensible_spread() {
    let truth = five_storey().modes().unwrap();
    let mut zf = Vec::new();
    for seed in [1, 2, 3] {
        let errors = normalised_errors(&truth, &ambient_input_seeded(seed), Method::SsiCov);
        eprintln!("seed {seed}: {errors:?}");
        for (j, e) in errors.iter().enumerate() {
            let (f, _, _, _) = e.unwrap_or_else(|| panic!("seed {seed}: mode {} without σ", j + 1));
            zf.push(f);
        }
    }
    let rms = (zf.iter().map(|z| z * z).sum::<f64>() / zf.len() as f64).sqrt();
    eprintln!("rms of (f̂ − f)/σ_f over {} estimates: {rms:.2}", zf.len());
    assert!((0.4..=2.0).contains(&rms), "rms {rms:.2}");
}

/// CI version of the coverage study for input–output: twenty seeds of the
/// 40-s earthquake with base input (30 dB).  Every mode gets a σ; Eq. S8'
/// counts the 20 blocks of a transient record as fewer (its power lies in
/// the strong phase); Eq. S9 is exercised (on these seeds the valid-order
/// pole of mode 3 or 4 disagrees with the reported estimate in 13–22 % of
/// the seeds: here at least twice); and the 100 normalised frequency errors
/// have an rms in [0.6, 1.6] (1 for a correct σ; the 95 % range of an exact
/// σ over 100 values is about 0.86–1.14).
#[test]
fn earthquake_normalised_errors_have_a_sensible_spread() {
    use quaketwin::modal::uncertainty::StdBasis;
    let truth = five_storey().modes().unwrap();
    let (mut zf, mut switched) = (Vec::new(), 0);
    for seed in 1..=20 {
        let errors = per_true_mode(
            &truth,
            &earthquake_input_with_noise(seed, 30.0),
            Method::Io,
            |j, m, d| {
                assert!(
                    d.dof < d.blocks as f64 - 1.0 && d.dof >= 3.0,
                    "seed {seed}: {} blocks, {} degrees of freedom",
                    d.blocks,
                    d.dof
                );
                (
                    (m.frequency_hz - truth.frequencies_hz[j]) / d.frequency_hz,
                    d.basis,
                )
            },
        );
        for (j, e) in errors.iter().enumerate() {
            let (z, basis) = e.unwrap_or_else(|| panic!("seed {seed}: mode {} without σ", j + 1));
            zf.push(z);
            switched += (basis == StdBasis::Discrepancy) as usize;
        }
    }
    let rms = (zf.iter().map(|z| z * z).sum::<f64>() / zf.len() as f64).sqrt();
    eprintln!(
        "rms of (f̂ − f)/σ_f over {} estimates: {rms:.2}; {switched} with Eq. S9",
        zf.len()
    );
    assert!((0.6..=1.6).contains(&rms), "rms {rms:.2}");
    assert!(
        switched >= 2,
        "Eq. S9 used {switched} times on twenty seeds"
    );
}

/// Coverage of the 95 % intervals f̂ ± k σ_f and ζ̂ ± k σ_ζ
/// (k = t_{0.975, ν}, Eqs. S8–S8' of docs/statistics.md) over
/// `seeds` (in parallel), per mode: (covered f, covered ζ, identified with
/// σ, rms of (f̂ − f)/σ_f, rms of (ζ̂ − ζ)/σ_ζ).
fn coverage(
    seeds: &[u64],
    method: Method,
    input: impl Fn(u64) -> ModalInput + Sync,
) -> Vec<(usize, usize, usize, f64, f64)> {
    use rayon::prelude::*;
    let truth = five_storey().modes().unwrap();
    let all: Vec<Vec<Option<(f64, f64, f64, bool)>>> = seeds
        .par_iter()
        .map(|&seed| normalised_errors(&truth, &input(seed), method))
        .collect();
    let mut out = vec![(0, 0, 0, 0.0, 0.0); 5];
    for (seed, errors) in seeds.iter().zip(&all) {
        eprintln!(
            "  {} seed {seed:3}: normalised errors (f, ζ) {}",
            method.name(),
            errors
                .iter()
                .map(|e| e.map_or("—".into(), |(f, z, _, _)| format!("{f:+.2} {z:+.2}")))
                .collect::<Vec<_>>()
                .join(" | ")
        );
        for (j, e) in errors.iter().enumerate() {
            if let Some((f, z, k, _)) = e {
                out[j].2 += 1;
                out[j].0 += (f.abs() <= *k) as usize;
                out[j].1 += (z.abs() <= *k) as usize;
                out[j].3 += f * f;
                out[j].4 += z * z;
            }
        }
    }
    for o in out.iter_mut() {
        let n = o.2.max(1) as f64;
        o.3 = (o.3 / n).sqrt();
        o.4 = (o.4 / n).sqrt();
    }
    let s9: Vec<usize> = (0..5)
        .map(|j| all.iter().filter(|e| e[j].is_some_and(|x| x.3)).count())
        .collect();
    eprintln!(
        "  {} seeds with Eq. S9 (the discrepancy added), per mode: {s9:?}",
        method.name()
    );
    // Each half of the seeds apart: how much a 100-seed table moves.
    for (half, range) in all.chunks(all.len().div_ceil(2)).enumerate() {
        let cells: Vec<String> = (0..5)
            .map(|j| {
                let hits = |q: usize| {
                    range
                        .iter()
                        .filter_map(|e| e[j])
                        .filter(|&(f, z, k, _)| [f, z][q].abs() <= k)
                        .count()
                };
                format!("mode {} {}/{}", j + 1, hits(0), hits(1))
            })
            .collect();
        eprintln!(
            "  {} half {} of the seeds ({} seeds), covered f/ζ: {}",
            method.name(),
            half + 1,
            range.len(),
            cells.join(", ")
        );
    }
    out
}

fn print_coverage(title: &str, seeds: usize, cov: &[(usize, usize, usize, f64, f64)]) {
    let truth = five_storey().modes().unwrap();
    eprintln!("{title} ({seeds} seeds)");
    eprintln!("| mode | f (Hz) | ζ | identified with σ | f covered | ζ covered | rms of (f̂ − f)/σ_f | rms of (ζ̂ − ζ)/σ_ζ |");
    eprintln!("|---|---|---|---|---|---|---|---|");
    for (j, (cf, cz, n, rf, rz)) in cov.iter().enumerate() {
        eprintln!(
            "| {} | {:.3} | {:.3} | {n}/{seeds} | {:.0} % | {:.0} % | {rf:.2} | {rz:.2} |",
            j + 1,
            truth.frequencies_hz[j],
            truth.damping_ratios[j],
            100.0 * *cf as f64 / (*n).max(1) as f64,
            100.0 * *cz as f64 / (*n).max(1) as f64,
        );
    }
}

/// The issue-36 coverage study: 200 seeds each of the 600-s ambient record
/// (SSI-COV) and of the 40-s earthquake with base input (io), default
/// settings; the 95 % intervals must contain the truth in 90–99 % of the
/// seeds for every mode's frequency and damping.
/// Run: `cargo test --release --test it uncertainty::coverage_study -- --ignored --nocapture`
#[test]
#[ignore]
fn coverage_study_two_hundred_seeds() {
    let seeds: Vec<u64> = (1..=200).collect();
    let ambient = coverage(&seeds, Method::SsiCov, ambient_input_seeded);
    let quake = coverage(&seeds, Method::Io, |s| earthquake_input_with_noise(s, 30.0));
    print_coverage("ssi-cov, 600-s ambient, 20 dB", seeds.len(), &ambient);
    print_coverage(
        "io, 40-s earthquake with base input, 30 dB",
        seeds.len(),
        &quake,
    );
    let mut failures = Vec::new();
    for (kind, cov) in [("ssi-cov", &ambient), ("io", &quake)] {
        for (j, (cf, cz, n, _, _)) in cov.iter().enumerate() {
            for (what, c) in [("f", cf), ("ζ", cz)] {
                let share = *c as f64 / seeds.len() as f64;
                if !(0.9..=0.99).contains(&share) || *n < seeds.len() {
                    failures.push(format!("{kind} mode {} {what}: {c}/{n} covered", j + 1));
                }
            }
        }
    }
    assert!(
        failures.is_empty(),
        "coverage outside 90–99 %: {failures:?}"
    );
}

/// The 14-channel × 41 s × 200 Hz event of `benches/modal.rs` (a 7-storey
/// building in plan, X and Y at one corner of floors 2–7 and at the base,
/// 20 dB): the modal stage's identification with and without the
/// data-driven σ, median wall time of 7 runs each, alternating.  The
/// criterion bench `modal_stage/14ch_41s_200Hz_*_no_uncertainty` measures
/// the same in release; this is the quick check of the ≤ 50 % target.
/// Run: `cargo test --test it uncertainty::cost_on_the_fourteen_channel_event -- --ignored --nocapture`
#[test]
#[ignore]
fn cost_on_the_fourteen_channel_event() {
    use quaketwin::modal::{identify_event, ChannelChoice};
    use quaketwin::stages::modal::ModalParams;
    let event = quaketwin::synth::fourteen_channel_event(false).unwrap();
    assert_eq!(event.records.len(), 14);
    let with = ModalParams::default().settings_for(&event).unwrap();
    let without = ModalSettings {
        uncertainty_blocks: Some(0),
        ..with.clone()
    };
    let choice = ChannelChoice::default();
    let r = identify_event(&event, &with, &choice).unwrap();
    eprintln!(
        "method {}, block rows {}, orders ≤ {:?}, modes: {}",
        r.method.name(),
        r.block_rows,
        r.orders.last(),
        r.modes
            .iter()
            .map(|m| format!(
                "{:.3} Hz σ {}",
                m.frequency_hz,
                m.data_std.as_ref().map_or("—".into(), |d| format!(
                    "{:.4} Hz ({} blocks)",
                    d.frequency_hz, d.blocks
                ))
            ))
            .collect::<Vec<_>>()
            .join(", ")
    );
    eprintln!("notes: {:?}\nwarnings: {:?}", r.notes.last(), r.warnings);
    let (mut a, mut b) = (Vec::new(), Vec::new());
    for _ in 0..7 {
        let t = std::time::Instant::now();
        identify_event(&event, &without, &choice).unwrap();
        a.push(t.elapsed().as_secs_f64());
        let t = std::time::Instant::now();
        identify_event(&event, &with, &choice).unwrap();
        b.push(t.elapsed().as_secs_f64());
    }
    let (a, b) = (
        quaketwin::stats::median_in_place(&mut a),
        quaketwin::stats::median_in_place(&mut b),
    );
    eprintln!(
        "identification without σ {:.3} s, with σ {:.3} s: +{:.0} %",
        a,
        b,
        100.0 * (b / a - 1.0)
    );
}

/// The choice of Eq. S7 (docs/statistics.md): coverage of the 95 %
/// intervals over 100 seeds for the valid-order σ alone, √(σ² + s²) (the
/// rule) and √(σ² + s²/n) (n poles averaged).  Prints only.  Since Eq. S9
/// only the modes whose σ is of the valid orders (`valid_orders`) can give
/// σ_valid back; the others are left out (the counts say how many).
/// Run: `cargo test --test it uncertainty::coverage_variants -- --ignored --nocapture`
#[test]
#[ignore]
fn coverage_variants_hundred_seeds() {
    use rayon::prelude::*;
    let truth = five_storey().modes().unwrap();
    for (kind, method) in [("ssi-cov", Method::SsiCov), ("io", Method::Io)] {
        let seeds: Vec<u64> = (1..=100).collect();
        // per seed, per mode: (ef, ez, σf, σz, sf, sz, n)
        let all: Vec<Vec<Option<[f64; 7]>>> = seeds
            .par_iter()
            .map(|&seed| {
                let input = if method == Method::SsiCov {
                    ambient_input_seeded(seed)
                } else {
                    earthquake_input_with_noise(seed, 30.0)
                };
                per_true_mode(&truth, &input, method, |j, m, d| {
                    (d.basis == quaketwin::modal::uncertainty::StdBasis::ValidOrders).then(|| {
                        [
                            m.frequency_hz - truth.frequencies_hz[j],
                            m.damping_ratio - truth.damping_ratios[j],
                            // σ_valid back from the reported √(σ_valid² + s²)
                            (d.frequency_hz.powi(2) - m.frequency_std_hz.powi(2))
                                .max(0.0)
                                .sqrt(),
                            (d.damping.powi(2) - m.damping_std.powi(2)).max(0.0).sqrt(),
                            m.frequency_std_hz,
                            m.damping_std,
                            m.pole_count as f64,
                        ]
                    })
                })
                .into_iter()
                .map(Option::flatten)
                .collect()
            })
            .collect();
        let variants: [(&str, fn(f64, f64, f64) -> f64); 3] = [
            ("σ_valid", |s, _, _| s),
            ("√(σ² + s²)", |s, o, _| s.hypot(o)),
            ("√(σ² + s²/n)", |s, o, n| s.hypot(o / n.sqrt())),
        ];
        for (name, rule) in variants {
            eprintln!("{kind} {name}");
            for j in 0..5 {
                let (mut cf, mut cz, mut n) = (0, 0, 0);
                for e in all.iter().filter_map(|e| e[j]) {
                    n += 1;
                    cf += (e[0].abs() <= 1.96 * rule(e[2], e[4], e[6])) as usize;
                    cz += (e[1].abs() <= 1.96 * rule(e[3], e[5], e[6])) as usize;
                }
                let med = |k: usize| {
                    let mut v: Vec<f64> = all.iter().filter_map(|e| e[j]).map(|e| e[k]).collect();
                    quaketwin::stats::median_in_place(&mut v)
                };
                eprintln!(
                    "  mode {}: f {cf}/{n} ζ {cz}/{n}   median σf {:.2e} sf {:.2e} σz {:.2e} sz {:.2e} n {:.0}",
                    j + 1,
                    med(2),
                    med(4),
                    med(3),
                    med(5),
                    med(6)
                );
            }
        }
    }
}

/// The factor of the 95 % interval (Eq. S8): Student's t_{0.975, n_b − 1}
/// against tabulated values (Abramowitz & Stegun, Table 26.10: 2.2622 for
/// 9, 2.0930 for 19, 2.0452 for 29 degrees of freedom), tending to the
/// normal 1.960 for many; none below 1 degree of freedom.
#[test]
fn interval_factor_is_students_t_of_the_blocks() {
    for (dof, t) in [
        (9.0, 2.2622),
        (19.0, 2.0930),
        (29.0, 2.0452),
        (199.0, 1.9720),
    ] {
        let k = interval_factor(dof);
        assert!(
            (k - t).abs() < 5e-4,
            "{dof} degrees of freedom: {k} against {t}"
        );
    }
    // Eq. S8' gives fractional degrees of freedom: between its neighbours.
    let k = interval_factor(9.5);
    assert!(k < 2.2622 && k > 2.2281, "9.5 degrees of freedom: {k}");
    assert!(interval_factor(0.5).is_nan());
}

/// Eq. S8': the σ's degrees of freedom are Kish's effective count of the
/// blocks weighted by power (input–output) or power² (SSI-COV), minus
/// one: n_b − 1 for equal blocks; a record whose power lies in one block
/// has none; 20 blocks of which 5 carry 4 × the power of the others
/// count as (5·4 + 15)² / (5·16 + 15) = 12.9 (io) and
/// (5·16 + 15)² / (5·256 + 15) = 6.97 (SSI-COV).
#[test]
fn effective_degrees_of_freedom_follow_the_block_powers() {
    use quaketwin::modal::uncertainty::{block_powers, effective_dof};
    let equal = vec![2.5; 30];
    for method in [Method::SsiCov, Method::Io] {
        assert!((effective_dof(method, &equal) - 29.0).abs() < 1e-9);
        assert!(effective_dof(method, &[0.0, 7.0, 0.0, 0.0]).abs() < 1e-12);
    }
    let mut strong = vec![1.0; 20];
    strong[..5].iter_mut().for_each(|p| *p = 4.0);
    assert!((effective_dof(Method::Io, &strong) - (35.0f64.powi(2) / 95.0 - 1.0)).abs() < 1e-9);
    assert!(
        (effective_dof(Method::SsiCov, &strong) - (95.0f64.powi(2) / 1295.0 - 1.0)).abs() < 1e-9
    );
    // The blocks' powers: runs of `len` samples, every output summed.
    let a: Vec<f64> = (0..12).map(|i| i as f64).collect();
    let b = vec![1.0; 12];
    let p = block_powers(&[&a, &b], 3, 4);
    assert_eq!(p, vec![14.0 + 4.0, 126.0 + 4.0, 366.0 + 4.0]);
}

/// The 40-s earthquake record of `earthquake_input_with_noise(seed, 30)`
/// with the measured base input exact: the same floor records (the same
/// noise: drawn first from the same generator), no noise on the input.
fn earthquake_input_exact_base(seed: u64) -> ModalInput {
    let mut input = earthquake_input_with_noise(seed, 30.0);
    let (ag, dt) = crate::modal::earthquake_base_motion(seed);
    let response = five_storey().simulate_base_motion(&ag, dt).unwrap();
    input.inputs = vec![response.base_acceleration];
    input
}

/// Diagnosis of the coverage study's cells (docs/statistics.md, "Why three
/// cells missed"): per mode, over 100 seeds, the mean error against its
/// standard error and against the median σ (a bias?), the error's
/// standard deviation against the median σ (σ too small on the whole?),
/// and the σ of the seeds whose interval missed (a few seeds with too
/// small a σ?); for io also with the base input exact, the input's 30 dB
/// noise's part.  Prints only.
/// Run: `cargo test --test it uncertainty::coverage_diagnosis -- --ignored --nocapture`
#[test]
#[ignore]
fn coverage_diagnosis_hundred_seeds() {
    use rayon::prelude::*;
    let truth = five_storey().modes().unwrap();
    let seeds: Vec<u64> = (1..=100).collect();
    let kinds: [(&str, Method, fn(u64) -> ModalInput); 3] = [
        ("ssi-cov", Method::SsiCov, ambient_input_seeded),
        ("io", Method::Io, |s| earthquake_input_with_noise(s, 30.0)),
        ("io, exact input", Method::Io, earthquake_input_exact_base),
    ];
    for (kind, method, input) in kinds {
        // per seed, per mode: (e_f, e_ζ, σ_f, σ_ζ, k)
        let all: Vec<Vec<Option<[f64; 5]>>> = seeds
            .par_iter()
            .map(|&seed| {
                per_true_mode(&truth, &input(seed), method, |j, m, d| {
                    [
                        m.frequency_hz - truth.frequencies_hz[j],
                        m.damping_ratio - truth.damping_ratios[j],
                        d.frequency_hz,
                        d.damping,
                        interval_factor(d.dof),
                    ]
                })
            })
            .collect();
        eprintln!("{kind}: mean e / median σ (t of the mean), std e / median σ, covered, σ / median σ of the missed seeds");
        for j in 0..5 {
            let rows: Vec<[f64; 5]> = all.iter().filter_map(|e| e[j]).collect();
            let n = rows.len() as f64;
            let mut cells = Vec::new();
            for (e, s) in [(0, 2), (1, 3)] {
                let mean = rows.iter().map(|r| r[e]).sum::<f64>() / n;
                let sd =
                    (rows.iter().map(|r| (r[e] - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
                let mut sigmas: Vec<f64> = rows.iter().map(|r| r[s]).collect();
                let med = quaketwin::stats::median_in_place(&mut sigmas);
                let missed: Vec<f64> = rows
                    .iter()
                    .filter(|r| r[e].abs() > r[4] * r[s])
                    .map(|r| r[s] / med)
                    .collect();
                let (lo, hi) = missed
                    .iter()
                    .fold((f64::INFINITY, 0.0f64), |(a, b), &x| (a.min(x), b.max(x)));
                cells.push(format!(
                    "{:+.2} (t {:+.1}), {:.2}, {:.0} %, {lo:.2}–{hi:.2}",
                    mean / med,
                    mean / (sd / n.sqrt()),
                    sd / med,
                    100.0 * (rows.len() - missed.len()) as f64 / n,
                ));
            }
            eprintln!("  mode {}: f {} | ζ {}", j + 1, cells[0], cells[1]);
        }
    }
}
