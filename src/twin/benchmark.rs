//! The thesis's benchmark twin (§3.3.2, Tables 6–8) as a twin file, for tests, benchmarks and
//! the documentation: a 3 m vertical cantilever in the x–y plane, three 1 m portions of 10
//! Timoshenko beam elements each, 0.1 × 0.1 m square section (κ = 5/6), ρ = 1800 kg/m³,
//! E = 1e9 / 2e9 / 2.5e9 Pa, ν = 0.3 (not printed in the thesis; shear deformation barely
//! matters at L/h = 30). Sensors: "h1" (ux at 1 m) and "top" (ux at 3 m). Parameters E1–E3
//! with bounds [1e8, 1e10] Pa and the start value `start`.

/// True Young's moduli of the three portions (Table 7).
pub const TRUE_MODULI: [f64; 3] = [1.0e9, 2.0e9, 2.5e9];

/// TOML text of the benchmark cantilever with all three parameters starting at `start`.
pub fn thesis_cantilever_toml(start: [f64; 3]) -> String {
    let mut s = String::new();
    s.push_str("[twin]\nname = \"thesis benchmark cantilever (ch. 3.3.2)\"\ndimension = 2\n\n");
    for (i, e) in TRUE_MODULI.iter().enumerate() {
        s.push_str(&format!(
            "[[materials]]\nname = \"portion{}\"\nE = {e:e}\nnu = 0.3\nrho = 1800.0\n\n",
            i + 1
        ));
    }
    s.push_str("[[sections]]\nname = \"square\"\nA = 0.01\nIz = 8.333333333333334e-6\nshear_factor = 0.8333333333333334\n\n");
    s.push_str("[mesh]\nnodes = [\n");
    for i in 0..=30 {
        s.push_str(&format!("  [{}, 0.0, {:.1}],\n", i + 1, 0.1 * i as f64));
    }
    s.push_str("]\n\n");
    for portion in 0..3 {
        s.push_str(&format!(
            "[[elements]]\ntype = \"beam2d\"\nmaterial = \"portion{p}\"\nsection = \"square\"\ngroup = \"portion{p}\"\nconnectivity = [",
            p = portion + 1
        ));
        let rows: Vec<String> = (0..10)
            .map(|k| {
                let e = portion * 10 + k + 1;
                format!("[{e}, {}, {}]", e, e + 1)
            })
            .collect();
        s.push_str(&rows.join(", "));
        s.push_str("]\n\n");
    }
    s.push_str("[[supports]]\nnodes = [1]\ndofs = [\"all\"]\n\n");
    for (i, v) in start.iter().enumerate() {
        s.push_str(&format!(
            "[[parameters]]\nname = \"E{n}\"\nkind = \"youngs_modulus\"\ngroups = [\"portion{n}\"]\nlower = 1.0e8\nupper = 1.0e10\nstart = {v:e}\n\n",
            n = i + 1
        ));
    }
    s.push_str("[[sensors]]\nchannel = \"h1\"\nnode = 11\ndof = \"ux\"\n\n");
    s.push_str("[[sensors]]\nchannel = \"top\"\nnode = 31\ndof = \"ux\"\n");
    s
}

/// TOML text of a flat rectangular shell plate (`nx` × `ny` shell4 elements, lx × ly m,
/// 0.2 m concrete: E = 30 GPa, ν = 0.2, ρ = 2400 kg/m³) clamped along x = 0 — the
/// large-model eigen benchmark (6 DoFs per node: (nx+1)(ny+1)·6 − 6(ny+1) free DoFs).
pub fn shell_plate_toml(nx: usize, ny: usize, lx: f64, ly: f64) -> String {
    let mut s = String::with_capacity(80 * (nx + 1) * (ny + 1) + 40 * nx * ny);
    s.push_str("[twin]\nname = \"clamped shell plate\"\ndimension = 3\n\n");
    s.push_str("[[materials]]\nname = \"concrete\"\nE = 30.0e9\nnu = 0.2\nrho = 2400.0\n\n");
    s.push_str("[[sections]]\nname = \"slab\"\nthickness = 0.2\n\n[mesh]\nnodes = [\n");
    for j in 0..=ny {
        for i in 0..=nx {
            s.push_str(&format!(
                "[{}, {:e}, {:e}, 0.0],\n",
                j * (nx + 1) + i + 1,
                lx * i as f64 / nx as f64,
                ly * j as f64 / ny as f64
            ));
        }
    }
    s.push_str("]\n\n[[elements]]\ntype = \"shell4\"\nmaterial = \"concrete\"\nsection = \"slab\"\ngroup = \"slab\"\nconnectivity = [\n");
    for j in 0..ny {
        for i in 0..nx {
            let n1 = j * (nx + 1) + i + 1;
            s.push_str(&format!(
                "[{}, {}, {}, {}, {}],\n",
                j * nx + i + 1,
                n1,
                n1 + 1,
                n1 + nx + 2,
                n1 + nx + 1
            ));
        }
    }
    s.push_str("]\n\n[[supports]]\nnodes = [");
    let edge: Vec<String> = (0..=ny).map(|j| (j * (nx + 1) + 1).to_string()).collect();
    s.push_str(&edge.join(", "));
    s.push_str("]\ndofs = [\"all\"]\n");
    s
}
