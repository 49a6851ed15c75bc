//! Hybrid-test design (METHODS §5–6): rigid-body modes, POD, actuator layout, Guyan + rigid
//! reduction, Craig–Bampton prototype, on a planar masonry facade under El Centro 1940.

use std::path::Path;

use faer::Mat;
use quaketwin::design::craig_bampton::hybrid_bandwidth_hz;
use quaketwin::design::layout::{interface_gravity_forces, ControlMode};
use quaketwin::design::partition::partition_by_node_ids;
use quaketwin::design::plan::design_hybrid_test_with;
use quaketwin::design::plan::{design_hybrid_test, BaseComponent, BaseMotion, DesignSettings};
use quaketwin::design::pod::{pod, reconstruction_quality, wnrmse};
use quaketwin::design::recorded::{expand_recorded_deformation, RecordedResponse};
use quaketwin::design::rigid::{
    rigid_body_modes, ConstrainedSet, KERNEL_RELATIVE_TOLERANCE, MAX_CONSTRAINT_CONDITION,
};
use quaketwin::readers::{at2, ReadOptions};
use quaketwin::twin::newmark::{newmark_base_excitation, rayleigh_coefficients, NewmarkSettings};
use quaketwin::twin::{dense_modes, parse_twin, Twin};
use quaketwin::vocab::SourceRef;

fn twin(text: &str) -> Twin {
    parse_twin(text, "test.toml", Path::new(".")).expect("valid twin")
}

/// Rectangular patch nx × ny of `kind` elements over [0, lx] × [0, ly], mapped by `place`.
fn patch_toml(
    kind: &str,
    dim: usize,
    nx: usize,
    ny: usize,
    lx: f64,
    ly: f64,
    place: impl Fn(f64, f64) -> [f64; 3],
) -> String {
    let mut nodes = Vec::new();
    for j in 0..=ny {
        for i in 0..=nx {
            let p = place(lx * i as f64 / nx as f64, ly * j as f64 / ny as f64);
            let coords: Vec<String> = p.iter().take(dim).map(|v| format!("{v:e}")).collect();
            nodes.push(format!("[{}, {}]", j * (nx + 1) + i + 1, coords.join(", ")));
        }
    }
    let mut conn = Vec::new();
    for j in 0..ny {
        for i in 0..nx {
            let n1 = j * (nx + 1) + i + 1;
            conn.push(format!(
                "[{}, {}, {}, {}, {}]",
                j * nx + i + 1,
                n1,
                n1 + 1,
                n1 + nx + 2,
                n1 + nx + 1
            ));
        }
    }
    format!(
        "[twin]\nname = \"patch\"\ndimension = {dim}\n[[materials]]\nname = \"m\"\nE = 1.5e9\nnu = 0.2\nrho = 1800.0\n\
         [[sections]]\nname = \"t\"\nthickness = 0.4\n[mesh]\nnodes = [{}]\n\
         [[elements]]\ntype = \"{kind}\"\nmaterial = \"m\"\nsection = \"t\"\ngroup = \"g\"\nconnectivity = [{}]\n",
        nodes.join(", "),
        conn.join(", ")
    )
}

/// |K R| relative and RᵀR = I for the kernel found.
fn check_kernel(t: &Twin, expected: usize) {
    let k = t.system.stiffness_at(&[]).to_dense();
    let rb = rigid_body_modes(k.as_ref(), KERNEL_RELATIVE_TOLERANCE).unwrap();
    assert_eq!(
        rb.count(),
        expected,
        "eigenvalues {:?}",
        &rb.eigenvalues[..expected + 2]
    );
    let kr = &k * &rb.modes;
    let kmax = rb.eigenvalues.last().unwrap();
    for j in 0..expected {
        let norm = (0..kr.nrows())
            .map(|i| kr[(i, j)].powi(2))
            .sum::<f64>()
            .sqrt();
        assert!(norm <= 1e-10 * kmax, "|K r_{j}| = {norm:e}");
    }
    let (last_zero, first_elastic) = rb.gap();
    assert!(
        last_zero < 1e-13 && first_elastic > 1e-7,
        "gap {last_zero:e} {first_elastic:e}"
    );
    // The proposed constrained set removes the rigid motion: a statically determined support.
    let set = ConstrainedSet::propose(&rb, MAX_CONSTRAINT_CONDITION).unwrap();
    assert_eq!(set.constrained.len(), expected);
    assert!(set.condition < 1e3, "condition {}", set.condition);
}

#[test]
fn free_q4_patch_has_three_rigid_body_modes() {
    check_kernel(
        &twin(&patch_toml("q4", 2, 3, 2, 1.5, 1.0, |x, y| {
            [x + 0.1 * y, y, 0.0]
        })),
        3,
    );
}

#[test]
fn free_shell_patch_has_six_rigid_body_modes() {
    check_kernel(
        &twin(&patch_toml("shell4", 3, 2, 2, 2.0, 2.0, |x, y| {
            [x, 0.6 * y, 0.8 * y + 0.1 * x]
        })),
        6,
    );
}

#[test]
fn q4_patch_rejects_constrained_sets_that_leave_rigid_motion() {
    let t = twin(&patch_toml("q4", 2, 2, 2, 1.0, 1.0, |x, y| [x, y, 0.0]));
    let k = t.system.stiffness_at(&[]).to_dense();
    let rb = rigid_body_modes(k.as_ref(), KERNEL_RELATIVE_TOLERANCE).unwrap();
    let map = t.system.dofs.as_ref().unwrap();
    let at = |node: usize, dof: usize| map.free_index(node, dof).unwrap();
    // ux at three nodes of the bottom edge (nodes 0, 1, 2): vertical translation is free.
    let err = ConstrainedSet::validated(
        &rb,
        vec![at(0, 0), at(1, 0), at(2, 0)],
        MAX_CONSTRAINT_CONDITION,
    )
    .unwrap_err();
    assert!(
        err.to_string()
            .contains("does not remove the rigid-body modes"),
        "{err}"
    );
    // Two DoFs only: wrong count.
    assert!(
        ConstrainedSet::validated(&rb, vec![at(0, 0), at(0, 1)], MAX_CONSTRAINT_CONDITION).is_err()
    );
    // A pinned node plus the far corner's uy: statically determined, accepted.
    let ok = ConstrainedSet::validated(
        &rb,
        vec![at(0, 0), at(0, 1), at(2, 1)],
        MAX_CONSTRAINT_CONDITION,
    )
    .unwrap();
    assert!(ok.condition < 1e3);
}

/// Seeded SplitMix64 → uniform in [-1, 1).
fn splitmix(state: &mut u64) -> f64 {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
}

/// X = Σ_i a_i(t) p_i with three orthonormal spatial patterns and amplitudes of distinct
/// energy: POD recovers the patterns (|cos| ≈ 1), their energy fractions, and 3 POMs
/// reconstruct X exactly.
#[test]
fn pod_recovers_known_patterns() {
    let (n, nt) = (40, 300);
    let mut seed = 7u64;
    let raw = Mat::from_fn(n, 3, |_, _| splitmix(&mut seed));
    let q = raw.thin_svd().unwrap().U().to_owned(); // orthonormal patterns
    let amp = [5.0, 2.0, 0.5];
    let times: Vec<[f64; 3]> = (0..nt)
        .map(|k| {
            let t = k as f64 * 0.01;
            [(2.0 * t).sin(), (7.3 * t).cos(), (19.0 * t).sin()]
        })
        .collect();
    let x = Mat::from_fn(n, nt, |i, k| {
        (0..3).map(|j| amp[j] * times[k][j] * q[(i, j)]).sum()
    });
    let p = pod(x.as_ref()).unwrap();
    // Time functions are not exactly orthogonal over the window: compare the energies of the
    // POD with the energy of the exact projection Σ_k (q_jᵀ x_k)² of each pattern.
    let total: f64 = (0..n)
        .flat_map(|i| (0..nt).map(move |k| (i, k)))
        .map(|(i, k)| x[(i, k)].powi(2))
        .sum();
    for j in 0..3 {
        let cos: f64 = (0..n)
            .map(|i| p.modes[(i, j)] * q[(i, j)])
            .sum::<f64>()
            .abs();
        assert!(cos > 0.999, "pattern {j}: |cos| = {cos}");
        let e: f64 = (0..nt)
            .map(|k| times[k][j].powi(2) * amp[j] * amp[j])
            .sum::<f64>()
            / total;
        assert!(
            (p.energy_fraction[j] - e).abs() < 2e-3,
            "energy {j}: {} vs {e}",
            p.energy_fraction[j]
        );
    }
    assert!(p.singular_values[3] < 1e-10 * p.singular_values[0]);
    let curve = reconstruction_quality(x.as_ref(), &p, 5, 0.999999, Some(1e-10)).unwrap();
    assert_eq!(curve.retained, 3);
    assert!(curve.wnrmse[0] > curve.wnrmse[1] && curve.wnrmse[1] > curve.wnrmse[2]);
    assert!(curve.wnrmse[2] < 1e-12, "{:?}", curve.wnrmse);
}

/// METHODS §6 / thesis: hybrid bandwidth = highest prototype frequency / λ.
#[test]
fn hybrid_bandwidth_reproduces_thesis_arithmetic() {
    assert!((hybrid_bandwidth_hz(113.77, 200.0) - 0.569).abs() < 5e-4);
    assert!((hybrid_bandwidth_hz(276.83, 200.0) - 1.384).abs() < 5e-4);
}

// ------------------------------------------------------------------ the masonry facade

const NX: usize = 16; // 8 m in 0.5 m elements
const NY: usize = 12; // 6 m
const H: f64 = 0.5;

fn facade_node(i: usize, j: usize) -> i64 {
    (j * (NX + 1) + i + 1) as i64
}

/// 8 m × 6 m masonry wall, Q4 plane stress, t = 0.4 m, a 2 m × 2 m window at
/// x ∈ [3, 5], y ∈ [2.5, 4.5]; base fixed.
fn facade_toml() -> String {
    let in_window = |i: usize, j: usize| {
        let (xc, yc) = ((i as f64 + 0.5) * H, (j as f64 + 0.5) * H);
        (3.0..5.0).contains(&xc) && (2.5..4.5).contains(&yc)
    };
    let mut nodes = Vec::new();
    for j in 0..=NY {
        for i in 0..=NX {
            nodes.push(format!(
                "[{}, {:e}, {:e}]",
                facade_node(i, j),
                i as f64 * H,
                j as f64 * H
            ));
        }
    }
    let mut conn = Vec::new();
    for j in 0..NY {
        for i in 0..NX {
            if !in_window(i, j) {
                conn.push(format!(
                    "[{}, {}, {}, {}, {}]",
                    j * NX + i + 1,
                    facade_node(i, j),
                    facade_node(i + 1, j),
                    facade_node(i + 1, j + 1),
                    facade_node(i, j + 1)
                ));
            }
        }
    }
    let base: Vec<String> = (0..=NX).map(|i| facade_node(i, 0).to_string()).collect();
    format!(
        "[twin]\nname = \"facade\"\ndimension = 2\n[[materials]]\nname = \"masonry\"\nE = 1.5e9\nnu = 0.2\nrho = 1800.0\n\
         [[sections]]\nname = \"wall\"\nthickness = 0.4\n[mesh]\nnodes = [{}]\n\
         [[elements]]\ntype = \"q4\"\nmaterial = \"masonry\"\nsection = \"wall\"\ngroup = \"wall\"\nconnectivity = [{}]\n\
         [[supports]]\nnodes = [{}]\ndofs = [\"ux\", \"uy\"]\n",
        nodes.join(", "),
        conn.join(", "),
        base.join(", ")
    )
}

/// The first 10 s of El Centro along x, as the design's base motion.
fn el_centro_motion() -> BaseMotion {
    let (dt, acceleration) = el_centro_10s();
    BaseMotion {
        dt,
        components: vec![BaseComponent {
            axis: 0,
            acceleration,
        }],
        source: "elCentro.AT2".into(),
    }
}

/// El Centro 1940 NS (PEER AT2, g), first 10 s, in m/s².
fn el_centro_10s() -> (f64, Vec<f64>) {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../shared/records/peer-at2-records/elCentro.AT2"
    );
    let bytes = std::fs::read(path).expect("El Centro record");
    let source = SourceRef {
        file: path.into(),
        member: None,
        column: None,
        format: "at2".into(),
    };
    let contents = at2::read(&bytes, &source, &ReadOptions::default()).unwrap();
    let rec = &contents.records[0];
    let to_si = rec.channel.units.to_si_factor().unwrap();
    let dt = 1.0 / rec.channel.sampling_rate_hz;
    let n = ((10.0 / dt).round() as usize).min(rec.samples.len());
    (dt, rec.samples[..n].iter().map(|a| a * to_si).collect())
}

/// The "must show" on the planar masonry facade: rigid-body removal leaves no rigid
/// component (1e-10), the retained POMs carry ≥ 99.9 % of the energy, the Guyan + rigid-body
/// reduced twin reproduces the PS response with WNRMSE ≤ 1e-2, and the Craig–Bampton
/// prototype's lowest frequencies (below 40 Hz: the first two) are within 1 % of the full
/// twin's.
#[test]
fn facade_design_must_show() {
    let t = twin(&facade_toml());
    let sys = &t.system;
    let map = sys.dofs.as_ref().unwrap();

    // PS: the pier-and-spandrel region around the window, x ∈ [2, 6], y ∈ [1.5, 5.5]; floating.
    let ps_ids: Vec<i64> = (4..=12)
        .flat_map(|i| (3..=11).map(move |j| facade_node(i, j)))
        .collect();
    let (dt, accel) = el_centro_10s();
    assert_eq!(accel.len(), 500);
    let motion = BaseMotion {
        dt,
        components: vec![BaseComponent {
            axis: 0,
            acceleration: accel.clone(),
        }],
        source: "elCentro.AT2".into(),
    };
    let mut settings = DesignSettings::default();
    settings.hybrid.band_of_interest_hz = 40.0;
    let design = design_hybrid_test(&t, &ps_ids, &motion, &settings, "design.toml").unwrap();
    let part = &design.partition;
    assert_eq!(design.rigid.count(), 3);

    // 1. Rigid-body removal in the PS's own DoFs: no rigid component left, and the result
    //    ignores added rigid motion.
    let (k, m) = (sys.stiffness_at(&[]), sys.mass_at(&[]));
    let rigid = rigid_body_modes(part.ps_stiffness.as_ref(), KERNEL_RELATIVE_TOLERANCE).unwrap();
    let set = ConstrainedSet::propose(&rigid, MAX_CONSTRAINT_CONDITION).unwrap();
    let full_modes = dense_modes(k.to_dense().as_ref(), m.to_dense().as_ref(), 12).unwrap();
    let f = full_modes.frequencies_hz();
    let rayleigh = rayleigh_coefficients(f[0], f[3], 0.05, 0.05).unwrap();
    let exc = sys.base_excitation(&[], 0, accel).unwrap();
    let resp = newmark_base_excitation(
        &k,
        &m,
        &[exc],
        &NewmarkSettings {
            dt,
            rayleigh,
            record: Some(part.ps_free.clone()),
        },
    )
    .unwrap();
    let gravity = sys.gravity_response(&[]).unwrap();
    let ug_ps = part.restrict(&gravity.displacement);
    let history: Vec<Vec<f64>> = (0..resp.displacement[0].len())
        .map(|step| {
            (0..part.n_ps())
                .map(|p| ug_ps[p] + resp.displacement[p][step])
                .collect()
        })
        .collect();
    let (_, lambdas) = set.deformation_snapshots(&rigid, &history);
    let mut seed = 11u64;
    let mut worst_invariance = 0.0_f64;
    let mut worst_rigid = 0.0_f64;
    for (step, u) in history.iter().enumerate().step_by(25) {
        let (bar, _) = set.remove(&rigid, u);
        let norm = bar.iter().map(|v| v * v).sum::<f64>().sqrt();
        // Rigid part of ū in the c-decomposition u = ū_c-free + R α: α = (R^c)⁻¹ ū^c.
        let (_, again) = set.remove(&rigid, &bar);
        let alpha = again.iter().map(|v| v.abs()).fold(0.0, f64::max);
        worst_rigid = worst_rigid.max(alpha / norm);
        // Add a large arbitrary rigid motion (100 × the deformation): ū must not change.
        let beta: Vec<f64> = (0..3).map(|_| 100.0 * norm * splitmix(&mut seed)).collect();
        let moved: Vec<f64> = (0..u.len())
            .map(|i| u[i] + (0..3).map(|j| rigid.modes[(i, j)] * beta[j]).sum::<f64>())
            .collect();
        let (bar2, _) = set.remove(&rigid, &moved);
        let diff = bar
            .iter()
            .zip(&bar2)
            .map(|(a, b)| (a - b).powi(2))
            .sum::<f64>()
            .sqrt();
        worst_invariance = worst_invariance.max(diff / norm);
        assert!(lambdas[step].iter().all(|v| v.is_finite()));
    }
    eprintln!("rigid removal: rigid part left {worst_rigid:e}, invariance to added rigid motion {worst_invariance:e}");
    assert!(worst_rigid <= 1e-10 && worst_invariance <= 1e-10);
    // The PS response does contain rigid motion (the whole wall sways), so removal mattered.
    let max_lambda = lambdas
        .iter()
        .flatten()
        .fold(0.0_f64, |a, v| a.max(v.abs()));
    assert!(max_lambda > 1e-6, "rigid amplitude {max_lambda:e}");

    // 2. POD: the retained POMs carry ≥ 99.9 % of the energy, and no fewer would.
    let p = &design.pod;
    let kept = design.pod_curve.retained;
    eprintln!(
        "POD energy {:?}, cumulative {:?}, WNRMSE {:?}, retained {kept}",
        &p.energy_fraction[..5],
        &p.cumulative_energy[..5],
        &design.pod_curve.wnrmse[..5]
    );
    assert!(p.cumulative_energy[kept - 1] >= 0.999);
    assert!(kept == 1 || p.cumulative_energy[kept - 2] < 0.999);

    // 3. The reduced twin (interface super-element + Guyan + rigid-body PS) against the full
    //    twin under the same motion.
    for s in &design.refinement {
        eprintln!(
            "control nodes {:2}, coupled {:2}, actuators {:2}: WNRMSE deformation {:.4e} total {:.4e}, f1 error {:+.4e}",
            s.control_nodes, s.coupled_dofs, s.actuators, s.wnrmse_deformation, s.wnrmse_total, s.first_frequency_error
        );
    }
    let v = &design.validation;
    eprintln!(
        "validation: WNRMSE deformation {:e}, total {:e}, max relative error {:e}",
        v.wnrmse, v.wnrmse_total, v.relative_max_error_total
    );
    assert!(v.wnrmse <= 1e-2, "deformation WNRMSE {}", v.wnrmse);
    assert!(v.wnrmse_total <= 1e-2, "total WNRMSE {}", v.wnrmse_total);
    // The refinement only stopped once the target was met, and started coarser.
    assert!(design.refinement.len() >= 2);
    assert!(design.refinement[0].wnrmse_deformation > 1e-2);

    // 4. Actuators: one per coupled DoF outside the constrained set; the NS carries the PS's
    //    weight through the interface (vertical interface forces sum to the PS weight).
    assert_eq!(
        design.actuators.len(),
        design.interface.coupled.len() - design.rigid.count()
    );
    for a in &design.actuators {
        eprintln!(
            "actuator {} node {} {} {} nominal {:.1} N participation {:?}",
            a.actuator,
            a.node_id,
            a.direction,
            a.control.name(),
            a.nominal_force,
            a.participation
        );
    }
    let fg = part.ps_gravity_load(sys.gravity, |a| map.dimension.translation_dof(a));
    let f_int = interface_gravity_forces(part, &ug_ps, &fg);
    let f_scale = f_int.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
    for (q, fq) in f_int.iter().enumerate() {
        if !part.interface.contains(&q) {
            assert!(
                fq.abs() <= 1e-8 * f_scale,
                "interior PS DoF {q} carries {fq} N"
            );
        }
    }
    let weight: f64 = fg.iter().sum();
    let vertical: f64 = part
        .ps_dofs
        .iter()
        .zip(&f_int)
        .filter(|((_, d), _)| *d == 1)
        .map(|(_, v)| v)
        .sum();
    assert!(
        (vertical + weight).abs() <= 1e-8 * weight.abs(),
        "{vertical} vs {weight}"
    );
    // Nominal actuator forces are the work-equivalent of those interface forces: together
    // with the constrained supports they carry the weight; at least one actuator does.
    assert!(design.actuators.iter().any(|a| a.nominal_force.abs() > 1.0));

    // 5. Craig–Bampton prototype: the full twin's frequencies below 40 Hz within 1 %.
    let rec = &design.hybrid;
    eprintln!(
        "CB: {} NS modes, matched {:?}, top {:.2} Hz, λ {}, bandwidth {:.3} Hz",
        rec.prototype.ns_modes,
        rec.matched,
        rec.prototype.highest_frequency_hz(),
        rec.time_scale,
        rec.bandwidth_hz
    );
    assert_eq!(rec.matched.len(), 2);
    for &(full, proto, err) in &rec.matched {
        assert!(err <= 0.01, "{full} vs {proto}");
    }
    assert!(rec.bandwidth_hz <= 2.0);
    let _ = ControlMode::Force;
}

/// Snapshot source (b): displacement "records" at 8 PS nodes (the PS corners and edge
/// midpoints, both directions; here the twin's own response, so the truth is known) give,
/// after rigid-body removal on the sensors and static expansion, the same dominant deformation
/// pattern as the full twin response, and the design proceeds from them.
#[test]
fn recorded_snapshots_recover_the_twin_deformation() {
    let t = twin(&facade_toml());
    let sys = &t.system;
    let model = t.model.as_ref().unwrap();
    let map = sys.dofs.as_ref().unwrap();
    let ps_ids: Vec<i64> = (4..=12)
        .flat_map(|i| (3..=11).map(move |j| facade_node(i, j)))
        .collect();
    let part = partition_by_node_ids(model, map, &ps_ids, "design.toml").unwrap();
    let (dt, accel) = el_centro_10s();
    let (k, m) = (sys.stiffness_at(&[]), sys.mass_at(&[]));
    let f = dense_modes(k.to_dense().as_ref(), m.to_dense().as_ref(), 4)
        .unwrap()
        .frequencies_hz();
    let resp = newmark_base_excitation(
        &k,
        &m,
        &[sys.base_excitation(&[], 0, accel.clone()).unwrap()],
        &NewmarkSettings {
            dt,
            rayleigh: rayleigh_coefficients(f[0], f[3], 0.05, 0.05).unwrap(),
            record: Some(part.ps_free.clone()),
        },
    )
    .unwrap();
    let sensors: Vec<(i64, String)> = [
        (4, 3),
        (8, 3),
        (12, 3),
        (4, 7),
        (12, 7),
        (4, 11),
        (8, 11),
        (12, 11),
    ]
    .iter()
    .flat_map(|&(i, j)| ["ux", "uy"].map(|d| (facade_node(i, j), d.to_string())))
    .collect();
    let displacement: Vec<Vec<f64>> = sensors
        .iter()
        .map(|(id, d)| {
            let node = model.node_index(*id).unwrap();
            let p = part.position(node, if d == "ux" { 0 } else { 1 }).unwrap();
            resp.displacement[p].clone()
        })
        .collect();
    let recorded = RecordedResponse {
        dofs: sensors.clone(),
        displacement,
        source: "synthetic records".into(),
    };

    // The expansion against the twin's own deformation, with the same constrained set.
    let rigid = rigid_body_modes(part.ps_stiffness.as_ref(), KERNEL_RELATIVE_TOLERANCE).unwrap();
    let expanded = expand_recorded_deformation(model, &part, &rigid, &recorded).unwrap();
    let history: Vec<Vec<f64>> = (0..resp.displacement[0].len())
        .map(|s| (0..part.n_ps()).map(|p| resp.displacement[p][s]).collect())
        .collect();
    let (x_twin, _) = expanded.set.deformation_snapshots(&rigid, &history);
    let (x_rec, _) = expanded
        .set
        .deformation_snapshots(&rigid, &expanded.history);
    let (w, _, _) = wnrmse(x_twin.as_ref(), x_rec.as_ref());
    eprintln!("expanded vs twin deformation: WNRMSE {w:e}");
    assert!(w <= 0.02, "WNRMSE {w}");

    let motion = BaseMotion {
        dt,
        components: vec![BaseComponent {
            axis: 0,
            acceleration: accel,
        }],
        source: "elCentro.AT2".into(),
    };
    let mut settings = DesignSettings::default();
    settings.hybrid.band_of_interest_hz = 40.0;
    let design = design_hybrid_test_with(
        &t,
        &ps_ids,
        &motion,
        Some(&recorded),
        &settings,
        "design.toml",
    )
    .unwrap();
    let mac = design.pom_mac.clone().unwrap();
    eprintln!(
        "recorded POD energy {:?}; MAC with the twin's POMs {:?}; {}",
        &design.pod.energy_fraction[..3],
        &mac[..3],
        design.snapshot_source
    );
    assert!(mac[0] >= 0.99, "MAC of POM 1: {}", mac[0]);
    assert!(design.snapshot_source.starts_with("records (16 DoFs"));
    assert!(design.validation.wnrmse <= 1e-2);

    // Too few sensors to separate deformation from rigid motion; a DoF outside the PS.
    let few = RecordedResponse {
        dofs: sensors[..3].to_vec(),
        displacement: recorded.displacement[..3].to_vec(),
        source: "three sensors".into(),
    };
    let err = expand_recorded_deformation(model, &part, &rigid, &few).unwrap_err();
    assert!(err.to_string().contains("at least 4"), "{err}");
    let outside = RecordedResponse {
        dofs: vec![(facade_node(0, 12), "ux".into())],
        displacement: vec![vec![0.0; 3]],
        source: "roof sensor".into(),
    };
    let err = expand_recorded_deformation(model, &part, &rigid, &outside).unwrap_err();
    assert!(err.to_string().contains("not a DoF of the PS"), "{err}");
}

/// A limit stated, not hidden: the PS reaching the free top edge (x ∈ [2, 6], y ∈ [2, 6]) with
/// the first three modes in band. Even with every interface node driven, the Guyan
/// condensation of the PS interior leaves the third frequency ≈ 4 % off: the design says so
/// instead of returning a layout that misses the target.
#[test]
fn design_reports_when_every_interface_node_is_not_enough() {
    let t = twin(&facade_toml());
    let ps_ids: Vec<i64> = (4..=12)
        .flat_map(|i| (4..=12).map(move |j| facade_node(i, j)))
        .collect();
    let motion = el_centro_motion();
    let mut settings = DesignSettings::default();
    settings.hybrid.band_of_interest_hz = 45.0;
    let err = design_hybrid_test(&t, &ps_ids, &motion, &settings, "design.toml").unwrap_err();
    let text = err.to_string();
    assert!(
        text.contains("every interface node is a control node"),
        "{text}"
    );
    assert!(
        text.contains("Guyan condensation of the PS interior"),
        "{text}"
    );
    // With only the first mode in band the same PS is designed within the targets.
    settings.hybrid.band_of_interest_hz = 20.0;
    let design = design_hybrid_test(&t, &ps_ids, &motion, &settings, "design.toml").unwrap();
    assert!(design.validation.wnrmse <= 1e-2 && design.validation.wnrmse_total <= 1e-2);
    assert!(design.hybrid.matched.iter().all(|m| m.2 <= 0.01));
}
