//! Issue 36 item 2: the subspace-based χ² change test (src/modal/change_test.rs,
//! docs/statistics.md "Change test") on the 5-storey shear building, and
//! the χ²/Hotelling distribution functions of src/stats.rs.

use crate::modal::five_storey;
use quaketwin::modal::change_test::{
    covariance_blocks, reference_from, ChangeReference, ChangeTestResult, ChangeTestSettings,
    CovarianceBlocks, HankelShape,
};
use quaketwin::stats::{
    chi2_survival, chi2_upper_quantile, hotelling_survival, hotelling_upper_quantile,
};
use quaketwin::synth::ShearBuilding;
use rayon::prelude::*;

#[test]
fn chi2_and_hotelling_against_tabulated_values() {
    // χ² tables (Abramowitz & Stegun 26.8): upper 5 % of χ²(1) 3.8415,
    // upper 1 % of χ²(10) 23.209, upper 1 % of χ²(100) 135.807.
    assert!((chi2_survival(3.841_459, 1.0) - 0.05).abs() < 1e-6);
    assert!((chi2_upper_quantile(0.01, 10.0) - 23.209_25).abs() < 1e-3);
    assert!((chi2_upper_quantile(0.01, 100.0) - 135.806_7).abs() < 1e-2);
    // χ²(2) survival is e^{−x/2} exactly.
    for x in [0.1, 1.0, 5.0, 30.0] {
        assert!((chi2_survival(x, 2.0) - (-x / 2.0f64).exp()).abs() < 1e-12);
    }
    // Hotelling's T² tends to χ² for a long reference, and is wider for a short one.
    let t_long = hotelling_upper_quantile(0.01, 10.0, 1e7);
    assert!((t_long / chi2_upper_quantile(0.01, 10.0) - 1.0).abs() < 1e-4);
    assert!(hotelling_upper_quantile(0.01, 10.0, 40.0) > 1.2 * t_long);
    assert!((hotelling_survival(t_long, 10.0, 1e7) - 0.01).abs() < 1e-6);
}

/// Ambient response of `building` (independent white floor forces),
/// `seconds` at `rate_hz`, floor accelerations with 20 dB noise — the
/// records of `ambient_input_seeded`, any length.
fn ambient_record(
    building: &ShearBuilding,
    seconds: f64,
    rate_hz: f64,
    seed: u64,
) -> Vec<Vec<f64>> {
    let n = (seconds * rate_hz) as usize;
    quaketwin::synth::five_storey::noisy_ambient(building, n, 1.0 / rate_hz, seed).unwrap()
}

/// The building with storey `storey` (0 = ground storey) `loss` softer.
fn damaged(storey: usize, loss: f64) -> ShearBuilding {
    let mut b = five_storey();
    b.storey_stiffness_n_per_m[storey] *= 1.0 - loss;
    b
}

fn blocks_of(record: &[Vec<f64>], settings: &ChangeTestSettings) -> CovarianceBlocks {
    let views: Vec<&[f64]> = record.iter().map(|s| s.as_slice()).collect();
    covariance_blocks(
        &views,
        shape().max_lag(),
        lag_step(),
        settings.blocks_per_record,
    )
    .unwrap()
}

/// Statistics of `seeds` windows of `building` against a reference of
/// `reference_seeds` healthy windows.
fn statistics(
    building: &ShearBuilding,
    reference: &ChangeReference,
    seconds: f64,
    rate_hz: f64,
    seeds: std::ops::Range<u64>,
    settings: &ChangeTestSettings,
) -> Vec<f64> {
    seeds
        .into_par_iter()
        .map(|seed| {
            let r = ambient_record(building, seconds, rate_hz, seed);
            reference
                .test(&blocks_of(&r, settings), settings.false_alarm_rate)
                .unwrap()
                .statistic
        })
        .collect()
}

/// Order 10 (the five modes) from five channels.
fn shape() -> HankelShape {
    let mut s = HankelShape::for_order(10, 5);
    if let Some(p) = std::env::var("CHANGE_P").ok().and_then(|v| v.parse().ok()) {
        s.block_rows = p;
        s.block_columns = p;
    }
    s
}

/// Lags in steps of 3 samples: at 100 Hz the 33 Hz the identification's
/// decimation would keep for the 12.4 Hz top mode (≥ 2.5 × the band's top).
fn lag_step() -> usize {
    std::env::var("CHANGE_LAG_STEP")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(3)
}

/// CI version: 10-minute windows at 50 Hz, a reference of four healthy
/// windows.  Three new healthy windows stay below the 1 % threshold (their
/// p-values are printed), and a 10 % loss of the ground storey's stiffness
/// is detected in each of three windows; the statistic's channel shares
/// add up to it.
#[test]
fn change_test_keeps_healthy_windows_and_detects_a_ten_percent_loss() {
    let settings = ChangeTestSettings::default();
    let (seconds, rate) = (600.0, 50.0);
    let healthy = five_storey();
    let refs: Vec<CovarianceBlocks> = (100..104)
        .map(|s| blocks_of(&ambient_record(&healthy, seconds, rate, s), &settings))
        .collect();
    let reference = reference_from(&refs, shape()).unwrap();
    let alpha = settings.false_alarm_rate;
    eprintln!(
        "dof {}, covariance dof {}, threshold {:.1}",
        reference.dof,
        reference.covariance_dof,
        reference.threshold(alpha).unwrap()
    );
    for seed in 200..203 {
        let r = ambient_record(&healthy, seconds, rate, seed);
        let t = reference.test(&blocks_of(&r, &settings), alpha).unwrap();
        eprintln!(
            "healthy seed {seed}: χ² {:.1}, p {:.3}",
            t.statistic, t.p_value
        );
        assert!(!t.changed, "healthy window {seed} flagged: {t:?}");
        let sum: f64 = t.channel_contributions.iter().sum();
        assert!((sum / t.statistic - 1.0).abs() < 1e-9);
    }
    let broken = damaged(0, 0.10);
    for seed in 300..303 {
        let r = ambient_record(&broken, seconds, rate, seed);
        let t = reference.test(&blocks_of(&r, &settings), alpha).unwrap();
        eprintln!(
            "damaged seed {seed}: χ² {:.1}, p {:.2e}",
            t.statistic, t.p_value
        );
        assert!(t.changed && t.p_value < 1e-6, "10 % loss missed: {t:?}");
        mode_shares_checked(&t, rate, t.statistic);
    }
}

/// Eq. C8 on a 10 % ground-storey loss: the two lowest modes (2.0 and
/// 5.3 Hz; at 50 Hz with lags every 3 samples the higher three alias above
/// 8.3 Hz) are reported at the building's frequencies (within 2 %), they
/// hold more than half of the statistic (the loss moves the low modes
/// most: −1.7, −1.5, −1.0, −0.6, −0.3 %), and what no mode explains is
/// under a tenth (measured: 73 % and 2.5 % for seed 300).
fn mode_shares_checked(t: &ChangeTestResult, rate: f64, statistic: f64) {
    let truth = five_storey().modes().unwrap().frequencies_hz;
    let shares: Vec<String> = t
        .mode_contributions
        .iter()
        .map(|m| {
            format!(
                "{:.2} Hz: {:.1}",
                m.frequency_per_sample * rate,
                m.contribution
            )
        })
        .collect();
    eprintln!(
        "  mode shares {shares:?}, unexplained {:.1} of {statistic:.1}",
        t.unexplained_contribution
    );
    let explained: f64 = t.mode_contributions.iter().map(|m| m.contribution).sum();
    assert!((explained + t.unexplained_contribution - statistic).abs() < 1e-9 * statistic);
    let low: f64 = truth[..2]
        .iter()
        .map(|f| {
            t.mode_contributions
                .iter()
                .find(|m| (m.frequency_per_sample * rate / f - 1.0).abs() < 0.02)
                .unwrap_or_else(|| panic!("no mode at {f:.2} Hz: {shares:?}"))
                .contribution
        })
        .sum();
    assert!(low > 0.5 * statistic, "{shares:?}");
    assert!(
        t.unexplained_contribution.abs() < 0.1 * statistic,
        "{shares:?}"
    );
}

/// A record of another shape or channel count is refused with a message.
#[test]
fn change_test_refuses_a_record_of_another_shape() {
    let settings = ChangeTestSettings::default();
    let healthy = five_storey();
    let r = ambient_record(&healthy, 600.0, 50.0, 1);
    let refs = vec![blocks_of(&r, &settings), blocks_of(&r, &settings)];
    let reference = reference_from(&refs, shape()).unwrap();
    let other = blocks_of(&r[..4], &settings);
    let e = reference.test(&other, 0.01).unwrap_err().to_string();
    assert!(e.contains("channels"), "{e}");
}

/// Two runs that decimated differently are compared at a common lag step:
/// the covariances of a record kept every sample, taken every second lag,
/// are those kept every second sample (the same blocks, the same lags), and
/// a step that is not a multiple, or leaves no lag, is refused.
#[test]
fn covariances_at_a_coarser_lag_step_are_the_coarser_records() {
    let r = ambient_record(&five_storey(), 120.0, 50.0, 3);
    let views: Vec<&[f64]> = r.iter().map(|s| s.as_slice()).collect();
    let fine = covariance_blocks(&views, 12, 1, 10).unwrap();
    let coarse = covariance_blocks(&views, 6, 2, 10).unwrap();
    let taken = fine.at_lag_step(2).unwrap();
    assert_eq!((taken.max_lag, taken.lag_step), (6, 2));
    assert_eq!(taken.mean, coarse.mean);
    assert_eq!(taken.blocks, coarse.blocks);
    assert_eq!(taken.block_power, coarse.block_power);
    assert_eq!(taken.samples, coarse.samples);
    // Every third lag of the fine record: lags 3, 6, 9, 12.
    assert_eq!(fine.at_lag_step(3).unwrap().max_lag, 4);
    assert!(coarse.at_lag_step(3).is_none(), "3 is not a multiple of 2");
    assert!(fine.at_lag_step(13).is_none(), "no lag left");
    // A stationary record's blocks have nearly equal powers (Eq. C4').
    let mean_power = fine.block_power.iter().sum::<f64>() / 10.0;
    assert!((mean_power - 1.0).abs() < 1e-12, "{mean_power}");
    assert!(
        fine.block_power.iter().all(|p| (p - 1.0).abs() < 0.2),
        "{:?}",
        fine.block_power
    );
}

/// Eq. C4': a record whose power lies in one of its blocks (an earthquake's
/// strong phase) has about one effective block, and no reference is built
/// from it; the same record at a steady level is a reference.
#[test]
fn a_record_with_its_power_in_one_block_is_no_reference() {
    let steady = ambient_record(&five_storey(), 600.0, 50.0, 4);
    let block = steady[0].len() / 12;
    let burst: Vec<Vec<f64>> = steady
        .iter()
        .map(|s| {
            s.iter()
                .enumerate()
                .map(|(i, v)| if i / block == 5 { 30.0 * v } else { *v })
                .collect()
        })
        .collect();
    let of = |r: &[Vec<f64>]| {
        let views: Vec<&[f64]> = r.iter().map(|s| s.as_slice()).collect();
        covariance_blocks(&views, shape().max_lag(), lag_step(), 12).unwrap()
    };
    assert!(reference_from(&[of(&steady)], shape()).is_ok());
    let e = reference_from(&[of(&burst)], shape())
        .unwrap_err()
        .to_string();
    assert!(e.contains("12 blocks count as 1.0"), "{e}");
}

fn env_count(name: &str, default: u64) -> u64 {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

/// Empirical ROC: (false-alarm rate, detection rate) at every threshold.
fn roc(null: &[f64], alternative: &[f64]) -> Vec<(f64, f64)> {
    let mut thresholds: Vec<f64> = null.iter().chain(alternative).copied().collect();
    thresholds.sort_by(|a, b| b.total_cmp(a));
    let mut points = vec![(0.0, 0.0)];
    for t in thresholds {
        let fa = null.iter().filter(|&&v| v >= t).count() as f64 / null.len() as f64;
        let pd = alternative.iter().filter(|&&v| v >= t).count() as f64 / alternative.len() as f64;
        points.push((fa, pd));
    }
    points.push((1.0, 1.0));
    points
}

/// Detection rate at the largest empirical threshold whose false-alarm
/// rate is ≤ `fa`.
fn power_at(null: &[f64], alternative: &[f64], fa: f64) -> f64 {
    let mut sorted = null.to_vec();
    sorted.sort_by(|a, b| b.total_cmp(a));
    // The threshold is the (⌊fa·n⌋+1)-th largest null statistic: strictly
    // more than it counts as an alarm, so at most ⌊fa·n⌋ false alarms.
    let allowed = (fa * null.len() as f64).floor() as usize;
    let t = sorted[allowed.min(sorted.len() - 1)];
    alternative.iter().filter(|&&v| v > t).count() as f64 / alternative.len() as f64
}

fn roc_svg(curves: &[(&str, &str, Vec<(f64, f64)>)], title: &str) -> String {
    // Log false-alarm axis 10⁻³…1 (the region that matters), linear power.
    let (w, h, left, bottom) = (560.0, 420.0, 60.0, 50.0);
    let x = |fa: f64| left + (w - left - 20.0) * ((fa.max(1e-3).log10() + 3.0) / 3.0);
    let y = |pd: f64| h - bottom - (h - bottom - 30.0) * pd;
    let mut s = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" font-family=\"sans-serif\" font-size=\"12\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n<text x=\"{}\" y=\"18\" text-anchor=\"middle\">{title}</text>\n",
        w / 2.0
    );
    for (k, fa) in [1e-3, 1e-2, 1e-1, 1.0].iter().enumerate() {
        s += &format!(
            "<line x1=\"{0}\" y1=\"{1}\" x2=\"{0}\" y2=\"{2}\" stroke=\"#ddd\"/><text x=\"{0}\" y=\"{3}\" text-anchor=\"middle\">{4}</text>\n",
            x(*fa), y(0.0), y(1.0), y(0.0) + 16.0, ["0.001", "0.01", "0.1", "1"][k]
        );
    }
    for pd in [0.0, 0.25, 0.5, 0.75, 0.95, 1.0] {
        s += &format!(
            "<line x1=\"{0}\" y1=\"{1}\" x2=\"{2}\" y2=\"{1}\" stroke=\"#ddd\"/><text x=\"{3}\" y=\"{4}\" text-anchor=\"end\">{pd}</text>\n",
            x(1e-3), y(pd), x(1.0), x(1e-3) - 4.0, y(pd) + 4.0
        );
    }
    s += &format!(
        "<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">false-alarm rate (healthy windows flagged)</text>\n<text x=\"14\" y=\"{}\" transform=\"rotate(-90 14 {})\" text-anchor=\"middle\">detection rate (power)</text>\n",
        x(0.0316), h - 10.0, y(0.5), y(0.5)
    );
    for (i, (label, colour, points)) in curves.iter().enumerate() {
        let path: Vec<String> = points
            .iter()
            .map(|&(fa, pd)| format!("{:.1},{:.1}", x(fa), y(pd)))
            .collect();
        s += &format!(
            "<polyline fill=\"none\" stroke=\"{colour}\" stroke-width=\"2\" points=\"{}\"/>\n<text x=\"{}\" y=\"{}\" fill=\"{colour}\">{label}</text>\n",
            path.join(" "),
            x(0.12),
            y(0.3) + 16.0 * i as f64
        );
    }
    s + "</svg>\n"
}

/// Issue 36 "Must show": ROC of the χ² test for a 1, 2 and 5 % stiffness
/// loss of the ground storey, one-hour ambient windows at 100 Hz (the
/// records of `ambient_input_seeded`, an hour long), a reference of ten
/// healthy hours.  Asserts ≥ 95 % power at a 1 % false-alarm rate for 2 %;
/// writes docs/figures/change-test-roc.svg and prints the table of
/// docs/statistics.md.
///
/// Run: `cargo test --release --test it change_test::roc_of_the_change_test -- --ignored --nocapture`
#[test]
#[ignore]
fn roc_of_the_change_test_one_hour_windows() {
    let settings = ChangeTestSettings::default();
    let (seconds, rate) = (3600.0, 100.0);
    let healthy = five_storey();
    let refs: Vec<CovarianceBlocks> = (1000..1010u64)
        .into_par_iter()
        .map(|s| blocks_of(&ambient_record(&healthy, seconds, rate, s), &settings))
        .collect();
    let reference = reference_from(&refs, shape()).unwrap();
    let threshold = reference.threshold(settings.false_alarm_rate).unwrap();
    let null = statistics(
        &healthy,
        &reference,
        seconds,
        rate,
        2000..2000 + env_count("CHANGE_ROC_NULL", 300),
        &settings,
    );
    let fa_theory = null.iter().filter(|&&v| v > threshold).count() as f64 / null.len() as f64;
    eprintln!(
        "dof {}, covariance dof {}, threshold (α = 1 %) {:.1}; healthy windows over it: {:.1} % of {}",
        reference.dof,
        reference.covariance_dof,
        threshold,
        100.0 * fa_theory,
        null.len()
    );
    let mut curves = Vec::new();
    let mut power_2 = 0.0;
    eprintln!("| stiffness loss | power at 1 % (empirical threshold) | power at 5 % | power at the α = 1 % threshold | median χ² |");
    for (loss, colour, seed0) in [
        (0.01, "#1b9e77", 3000u64),
        (0.02, "#d95f02", 4000),
        (0.05, "#7570b3", 5000),
    ] {
        let alt = statistics(
            &damaged(0, loss),
            &reference,
            seconds,
            rate,
            seed0..seed0 + env_count("CHANGE_ROC_ALT", 100),
            &settings,
        );
        let p1 = power_at(&null, &alt, 0.01);
        let p5 = power_at(&null, &alt, 0.05);
        let at_threshold = alt.iter().filter(|&&v| v > threshold).count() as f64 / alt.len() as f64;
        let mut sorted = alt.clone();
        sorted.sort_by(|a, b| a.total_cmp(b));
        eprintln!(
            "| {:.0} % | {:.1} % | {:.1} % | {:.1} % | {:.0} |",
            100.0 * loss,
            100.0 * p1,
            100.0 * p5,
            100.0 * at_threshold,
            sorted[sorted.len() / 2]
        );
        if loss == 0.02 {
            power_2 = p1;
        }
        curves.push((
            format!("{:.0} % loss, ground storey", 100.0 * loss),
            colour,
            roc(&null, &alt),
        ));
    }
    let labelled: Vec<(&str, &str, Vec<(f64, f64)>)> = curves
        .iter()
        .map(|(l, c, p)| (l.as_str(), *c, p.clone()))
        .collect();
    let svg = roc_svg(
        &labelled,
        "χ² change test, one-hour ambient windows, 5-storey shear building",
    );
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/figures");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("change-test-roc.svg"), svg).unwrap();
    assert!(
        power_2 >= 0.95,
        "power for a 2 % loss at 1 % false alarms: {power_2}"
    );
}
