//! The actuator layout of a hybrid-test design drawn on the twin: the
//! twin's nodes (the coordinates `actuator_layout/actuator_layout.parquet` carries in its
//! metadata, `quaketwin.nodes`), the physical substructure's nodes darker,
//! and an arrow per actuated DoF in its direction, coloured by control mode.
//! Drawn in the plane of the twin's two largest extents; inline SVG.

use std::collections::BTreeMap;

use serde_json::Value;

use crate::report::html::{escape, natural_cmp, note};
use crate::report::table::Table;
use crate::sinks::design_tables::NODES_KEY;
use crate::vocab::tables::actuator_layout;

const W: f64 = 620.0;
const MARGIN: f64 = 28.0;
const ARROW: f64 = 20.0;
const DISPLACEMENT: &str = "#0072b2";
const FORCE: &str = "#e69f00";

/// (id, [x, y, z]) of the listed nodes and the ids of the PS nodes.
type Nodes = (BTreeMap<i64, [f64; 3]>, Vec<i64>);

fn nodes(t: &Table) -> Option<Nodes> {
    let v: Value = serde_json::from_str(t.metadata.get(NODES_KEY)?).ok()?;
    let mut out = BTreeMap::new();
    for n in v.get("nodes")?.as_array()? {
        let a = n.as_array()?;
        let id = a.first()?.as_i64()?;
        let c = |i: usize| a.get(i).and_then(Value::as_f64).unwrap_or(0.0);
        out.insert(id, [c(1), c(2), c(3)]);
    }
    let ps = v
        .get("ps_nodes")
        .and_then(Value::as_array)
        .map(|a| a.iter().filter_map(Value::as_i64).collect())
        .unwrap_or_default();
    Some((out, ps))
}

/// The drawing, or a note saying why there is none.
pub(super) fn actuator_figure(t: &Table) -> String {
    let Some((nodes, ps)) = nodes(t) else {
        return note(
            "No node coordinates with the actuator layout (a design written by an earlier quaketwin): the layout is listed, not drawn.",
        );
    };
    if nodes.is_empty() {
        return note("The actuator layout lists no node coordinates: not drawn.");
    }
    // The drawing plane: the two axes of largest extent, first horizontal.
    let range = |k: usize| {
        let (lo, hi) = nodes
            .values()
            .fold((f64::MAX, f64::MIN), |(l, h), c| (l.min(c[k]), h.max(c[k])));
        (lo, hi)
    };
    let mut by_size: Vec<(usize, (f64, f64))> = (0..3).map(|k| (k, range(k))).collect();
    by_size.sort_by(|a, b| {
        (b.1 .1 - b.1 .0)
            .partial_cmp(&(a.1 .1 - a.1 .0))
            .unwrap_or(std::cmp::Ordering::Equal)
            .then(a.0.cmp(&b.0))
    });
    let (mut h, mut v) = (by_size[0], by_size[1]);
    if h.0 > v.0 {
        std::mem::swap(&mut h, &mut v);
    }
    let span = |r: (f64, f64)| (r.1 - r.0).max(1e-9);
    let scale = ((W - 2.0 * MARGIN) / span(h.1)).min(360.0 / span(v.1));
    let height = span(v.1) * scale + 2.0 * MARGIN;
    let px = |c: &[f64; 3]| {
        (
            MARGIN + (c[h.0] - h.1 .0) * scale,
            height - MARGIN - (c[v.0] - v.1 .0) * scale,
        )
    };
    let axis_name = ["x", "y", "z"];
    let mut svg = format!(
        "<svg class=\"plot actuators\" viewBox=\"0 0 {W} {height:.0}\" width=\"{W}\" height=\"{height:.0}\" role=\"img\" aria-label=\"actuator layout\">"
    );
    let ps_set: std::collections::BTreeSet<i64> = ps.iter().copied().collect();
    for (id, c) in &nodes {
        let (x, y) = px(c);
        let (r, fill) = if ps_set.contains(id) {
            (2.6, "#555")
        } else {
            (1.6, "#bbb")
        };
        svg.push_str(&format!(
            "<circle cx=\"{x:.1}\" cy=\"{y:.1}\" r=\"{r}\" fill=\"{fill}\"/>"
        ));
    }
    let ids = t.number(actuator_layout::NODE_ID.name).unwrap_or(&[]);
    let mut counts = (0usize, 0usize);
    for r in 0..t.rows {
        let Some(c) = ids
            .get(r)
            .copied()
            .flatten()
            .and_then(|id| nodes.get(&(id as i64)))
        else {
            continue;
        };
        let dir = t
            .key(actuator_layout::DIRECTION.name, r)
            .unwrap_or_default();
        let force = t.key(actuator_layout::CONTROL_MODE.name, r).as_deref() == Some("force");
        let colour = if force { FORCE } else { DISPLACEMENT };
        if force {
            counts.1 += 1;
        } else {
            counts.0 += 1;
        }
        let (x, y) = px(c);
        // A translation along a drawn axis: an arrow; out of the plane or a
        // rotation: a ring.
        let along = |k: usize| dir == format!("u{}", axis_name[k]);
        let (dx, dy) = if along(h.0) {
            (ARROW, 0.0)
        } else if along(v.0) {
            (0.0, -ARROW)
        } else {
            (0.0, 0.0)
        };
        if dx == 0.0 && dy == 0.0 {
            svg.push_str(&format!(
                "<circle cx=\"{x:.1}\" cy=\"{y:.1}\" r=\"6\" fill=\"none\" stroke=\"{colour}\" stroke-width=\"1.8\"/>"
            ));
        } else {
            let (ex, ey) = (x + dx, y + dy);
            // Arrowhead: a triangle at the end, 6 px long.
            let (ux, uy) = (dx / ARROW, dy / ARROW);
            let (bx, by) = (ex - 6.0 * ux, ey - 6.0 * uy);
            svg.push_str(&format!(
                "<line x1=\"{x:.1}\" y1=\"{y:.1}\" x2=\"{bx:.1}\" y2=\"{by:.1}\" stroke=\"{colour}\" stroke-width=\"2\"/>\
                 <polygon points=\"{ex:.1},{ey:.1} {:.1},{:.1} {:.1},{:.1}\" fill=\"{colour}\"/>",
                bx - 3.5 * uy,
                by + 3.5 * ux,
                bx + 3.5 * uy,
                by - 3.5 * ux
            ));
        }
    }
    svg.push_str(&format!(
        "<text x=\"{:.1}\" y=\"{:.1}\" font-size=\"11\" fill=\"#555\">{} →</text><text x=\"8\" y=\"{:.1}\" font-size=\"11\" fill=\"#555\">{} ↑</text></svg>",
        W - MARGIN - 20.0,
        height - 8.0,
        axis_name[h.0],
        MARGIN - 10.0,
        axis_name[v.0]
    ));
    let caption = format!(
        "Actuator layout on the twin ({}–{} plane, {:.1} m × {:.1} m): grey dots the twin's nodes, dark dots the physical \
         substructure's; arrows the actuated DoFs — blue displacement-controlled ({}), orange force-controlled ({}); a ring: \
         a DoF out of the drawing plane or a rotation.",
        axis_name[h.0],
        axis_name[v.0],
        span(h.1),
        span(v.1),
        counts.0,
        counts.1
    );
    format!(
        "<figure class=\"actuator-layout\" id=\"actuator-layout\">{svg}<figcaption>{}</figcaption></figure>",
        escape(&caption)
    )
}

/// The actuators by node in one paragraph: "node 12: ux, uy (displacement); …".
pub(super) fn actuator_list(t: &Table) -> String {
    let mut by_node: BTreeMap<String, Vec<String>> = BTreeMap::new();
    for r in 0..t.rows {
        let node = t.key(actuator_layout::NODE_ID.name, r).unwrap_or_default();
        let dir = t
            .key(actuator_layout::DIRECTION.name, r)
            .unwrap_or_default();
        let mode = match t.key(actuator_layout::CONTROL_MODE.name, r).as_deref() {
            Some("force") => " (force)",
            _ => "",
        };
        by_node
            .entry(node)
            .or_default()
            .push(format!("{dir}{mode}"));
    }
    let mut nodes: Vec<(String, Vec<String>)> = by_node.into_iter().collect();
    nodes.sort_by(|a, b| natural_cmp(&a.0, &b.0));
    let items: Vec<String> = nodes
        .iter()
        .map(|(n, d)| format!("node {n}: {}", d.join(", ")))
        .collect();
    format!(
        "<p class=\"note\" id=\"actuator-list\">{} actuators at {} nodes (displacement-controlled unless marked) — {}.</p>",
        t.rows,
        nodes.len(),
        escape(&items.join("; "))
    )
}
