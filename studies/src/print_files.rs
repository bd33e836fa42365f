//! Study `print-files`: confidently wrong builds over random designs wider than the
//! held-out proptest (issue 39). Its own generator draws modules (8–45 mm, PolyJet or
//! FDM with nozzles 0.25–0.8 mm and resolutions 0.016–0.2 mm, 3–8 pillars, 0–3
//! inserts, fiber holes from 0.6× the printer's floor up, clearances 0–0.3 mm) and
//! arrays (2–8 fibers, sheets 0.4–8 mm, slits from 0.6× the floor up); each is
//! validated and built whole, and every outcome checked from outside the build:
//!
//! - a build that succeeds but whose parts overlap (a vertex of one part more than
//!   [`OVERLAP_MM`] inside another, by ray parity and the exact point–triangle
//!   distance on the written meshes: the geometry crate's `assembly::Solid` queries,
//!   run here on every pair rather than trusting the build's own interference check);
//! - a fiber passage under the printer's floor (the spec's holes and slits against the
//!   floor as docs/geometry.md states it, recomputed here; a meshed passage narrower
//!   than the coated fiber);
//! - a meshed gap under 80 % of its design;
//! - a mesh that is not watertight (an edge not used exactly twice, in opposite
//!   directions);
//! - a refusal (of the spec or of the build) that names no field.
//!
//! Counts with Wilson 95 % intervals go to `print-files.json`, one row per scenario
//! to `print-files.csv`, and each confidently wrong draw's design to
//! `wrong-<seed>.toml`. `--quick` draws 12 scenarios.

use anyhow::Result;
use clap::Args;
use fbgforge::geometry::assembly::Solid;
use fbgforge::geometry::{self, BuiltPart, PartKind};
use fbgforge::progress::Progress;
use fbgforge::spec::{Design, PrintProcess};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::collections::HashMap;
use std::path::PathBuf;

/// How deep a vertex of one part must lie inside another to count as an overlap, mm
/// (press fits touch: their vertices lie on the other part's surface).
pub const OVERLAP_MM: f64 = 0.005;

/// Arguments of the `print-files` study.
#[derive(Debug, Args)]
pub struct PrintFilesArgs {
    /// Folder of the shipped designs the generator starts from.
    #[arg(long, default_value = "designs")]
    pub designs: PathBuf,
    /// Scenarios to draw.
    #[arg(long, default_value_t = 200)]
    pub scenarios: usize,
    /// First seed.
    #[arg(long, default_value_t = 3900)]
    pub seed: u64,
    /// Output folder for the CSV and JSON.
    #[arg(long, default_value = "out/study-print-files")]
    pub out: PathBuf,
    /// Smoke run: 12 scenarios.
    #[arg(long)]
    pub quick: bool,
}

/// What happened to one scenario.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct Row {
    /// Seed of the draw.
    pub seed: u64,
    /// `module` or `array`.
    pub kind: &'static str,
    /// `polyjet` or `fdm`.
    pub printer: &'static str,
    /// `built`, `refused-spec` or `refused-build`.
    pub outcome: &'static str,
    /// The refusal's message, or what was found wrong in a build.
    pub message: String,
    /// Confidently wrong: built with overlapping parts.
    pub overlap: bool,
    /// Confidently wrong: built with a passage under the printer's floor.
    pub under_floor: bool,
    /// Confidently wrong: built with a meshed gap under 80 % of its design.
    pub gap_eaten: bool,
    /// Confidently wrong: built with a mesh that is not watertight.
    pub not_watertight: bool,
    /// Confidently wrong: refused without naming a field or option.
    pub unnamed_refusal: bool,
}

impl Row {
    fn wrong(&self) -> bool {
        self.overlap
            || self.under_floor
            || self.gap_eaten
            || self.not_watertight
            || self.unnamed_refusal
    }
}

fn lerp(a: f64, b: f64, t: f64) -> f64 {
    a + (b - a) * t
}

/// A printer drawn wide: PolyJet (resolution 0.016–0.05 mm) or FDM (nozzle
/// 0.25–0.8 mm, resolution 0.05–0.2 mm).
fn draw_printer(rng: &mut ChaCha8Rng, d: &mut Design) {
    if rng.random_bool(0.5) {
        d.printer.process = PrintProcess::Fdm;
        let nozzle = lerp(0.25, 0.8, rng.random());
        d.printer.nozzle_diameter_mm = Some(nozzle);
        d.printer.resolution_mm = lerp(0.05, 0.2, rng.random());
        d.printer.min_wall_mm = nozzle;
    } else {
        d.printer.process = PrintProcess::Polyjet;
        d.printer.nozzle_diameter_mm = None;
        d.printer.resolution_mm = lerp(0.016, 0.05, rng.random());
        d.printer.min_wall_mm = lerp(0.2, 0.4, rng.random());
    }
}

/// The printer's floor for a fiber passage as docs/geometry.md states it, recomputed
/// here: PolyJet, the coated fiber + the resolution; FDM, the wider of that and the
/// nozzle, + the channel clearance.
pub fn floor_mm(d: &Design) -> f64 {
    let fiber = d.fiber_routing.coated_diameter_mm + d.printer.resolution_mm;
    match d.printer.process {
        PrintProcess::Fdm => {
            fiber.max(d.printer.nozzle_diameter_mm.unwrap_or(0.4))
                + d.fiber_routing.channel_clearance_mm
        }
        _ => fiber,
    }
}

/// A module drawn from a shipped one.
fn draw_module(rng: &mut ChaCha8Rng, base: &Design) -> Design {
    let mut d = base.clone();
    draw_printer(rng, &mut d);
    let floor = floor_mm(&d);
    let w = d.printer.min_wall_mm;
    let m = d.module.as_mut().expect("a module design");
    let r = lerp(8.0, 45.0, rng.random()) / 2.0;
    m.outer_diameter_mm = 2.0 * r;
    m.cap_wall_mm = lerp(w, 3.0_f64.min(0.25 * r), rng.random());
    m.core_wall_mm = lerp(w, 3.0_f64.min(0.25 * r), rng.random());
    let fit = |t: f64| if t < 0.1 { 0.0 } else { lerp(0.0, 0.3, t) };
    m.cap_core_clearance_mm = fit(rng.random());
    m.core_insert_clearance_mm = fit(rng.random());
    let pl = &mut m.pillars;
    pl.count = rng.random_range(3..=8);
    pl.fiber_hole_diameter_mm = lerp(0.6 * floor, 1.5, rng.random());
    pl.groove_depth_mm = lerp(0.05, 1.0, rng.random());
    pl.height_mm =
        (pl.fiber_hole_diameter_mm + 2.0 * w + pl.groove_depth_mm + lerp(0.05, 1.5, rng.random()))
            .min(0.3 * r);
    pl.groove_width_mm = lerp(w, 2.0, rng.random());
    pl.width_mm =
        pl.groove_width_mm.max(pl.fiber_hole_diameter_mm) + 2.0 * w + lerp(0.0, 2.0, rng.random());
    pl.first_pillar_angle_deg = 360.0 * rng.random::<f64>();
    m.dome_height_mm = lerp(0.3 * r, r, rng.random());
    m.overall_height_mm = m.dome_height_mm + lerp(4.0, 3.0 * r + 4.0, rng.random());
    m.top_hole_diameter_mm = lerp(0.6 * floor, 1.2, rng.random());
    m.inserts.truncate(rng.random_range(0..=3));
    if let Some(s) = m.snap.as_mut() {
        s.bead_height_mm = lerp(0.1, 0.6, rng.random());
        s.undercut_mm = lerp(0.0, 0.3, rng.random());
    }
    d
}

/// An array drawn from the shipped one: 2–8 fibers, a 0.4–8 mm sheet.
fn draw_array(rng: &mut ChaCha8Rng, base: &Design) -> Design {
    let mut d = base.clone();
    draw_printer(rng, &mut d);
    let floor = floor_mm(&d);
    let w = d.printer.min_wall_mm;
    let a = d.array.as_mut().expect("an array design");
    a.size_x_mm = lerp(20.0, 150.0, rng.random());
    a.size_y_mm = lerp(20.0, 150.0, rng.random());
    a.thickness_mm = lerp(0.4, 8.0, rng.random());
    let m = &mut a.mold;
    m.internal_x_mm = a.size_x_mm + lerp(2.0, 30.0, rng.random());
    m.internal_y_mm = a.size_y_mm + lerp(0.0, 30.0, rng.random());
    m.wall_thickness_mm = lerp(w, 5.0, rng.random());
    m.base_thickness_mm = lerp(w, 5.0, rng.random());
    m.wall_height_mm = a.thickness_mm + lerp(0.0, 5.0, rng.random());
    m.plugs = rng.random_bool(0.5);
    m.slit_width_mm = lerp(0.6 * floor, 1.2, rng.random());
    m.slit_depth_mm = f64::NAN;
    let fibers = rng.random_range(2..=8);
    let pitch = a.size_x_mm / fibers as f64;
    a.fiber_x_mm = (0..fibers)
        .map(|i| -a.size_x_mm / 2.0 + (i as f64 + 0.5) * pitch)
        .collect();
    let g = a.gratings[0].clone();
    a.gratings = vec![g];
    a.gratings[0].y_mm = 0.0;
    d.fill_derived();
    d
}

/// Whether a message names a spec field or a request option (`module.…`, `array.…`,
/// `printer.…`, `fiber_routing.…`, `materials.…`, `BuildRequest.…`).
pub fn names_field(message: &str) -> bool {
    const ROOTS: [&str; 7] = [
        "module.",
        "array.",
        "printer.",
        "fiber_routing.",
        "materials.",
        "BuildRequest.",
        "fibers.",
    ];
    message
        .split(|c: char| !(c.is_ascii_alphanumeric() || "._[]".contains(c)))
        .any(|t| ROOTS.iter().any(|r| t.starts_with(r) && t.len() > r.len()))
}

/// Whether every edge of every triangle is used exactly twice, once each way.
pub fn watertight(triangles: &[[u32; 3]]) -> bool {
    let mut directed: HashMap<(u32, u32), u32> = HashMap::new();
    for t in triangles {
        for k in 0..3 {
            *directed.entry((t[k], t[(k + 1) % 3])).or_default() += 1;
        }
    }
    directed
        .iter()
        .all(|(&(a, b), &n)| n == 1 && directed.get(&(b, a)) == Some(&1))
}

/// Whether a vertex of one part lies deeper than `allowed_mm` of the pair inside
/// another (up to 400 vertices of each part inside the other's box are tried).
pub fn parts_overlap(
    parts: &[&BuiltPart],
    allowed_mm: impl Fn(&BuiltPart, &BuiltPart) -> f64,
) -> Option<String> {
    for (i, a) in parts.iter().enumerate() {
        for (j, b) in parts.iter().enumerate() {
            if i == j {
                continue;
            }
            let allowed = allowed_mm(a, b);
            let (lo, hi) = b.mesh.bbox_mm();
            let candidates: Vec<[f64; 3]> = a
                .mesh
                .positions
                .iter()
                .copied()
                .filter(|p| (0..3).all(|k| p[k] > lo[k] && p[k] < hi[k]))
                .collect();
            let step = (candidates.len() / 400).max(1);
            let solid = Solid::new(&b.name, &b.mesh);
            for p in candidates.iter().step_by(step) {
                if solid.contains(*p) {
                    let depth = solid
                        .distance_within(*p, f64::INFINITY)
                        .unwrap_or(f64::INFINITY);
                    if depth > allowed {
                        return Some(format!(
                            "a vertex of {} at ({:.3}, {:.3}, {:.3}) lies {depth:.4} mm inside {} (allowed {allowed:.4} mm)",
                            a.name, p[0], p[1], p[2], b.name
                        ));
                    }
                }
            }
        }
    }
    None
}

/// Validate and build one design; check what came out.
fn judge(d: &Design, seed: u64) -> Row {
    let mut row = Row {
        seed,
        kind: if d.module.is_some() {
            "module"
        } else {
            "array"
        },
        printer: if d.printer.process == PrintProcess::Fdm {
            "fdm"
        } else {
            "polyjet"
        },
        ..Row::default()
    };
    let refused = |row: &mut Row, outcome, e: String| {
        row.outcome = outcome;
        row.unnamed_refusal = !names_field(&e);
        row.message = e;
    };
    if let Err(e) = d.validate() {
        refused(&mut row, "refused-spec", e.to_string());
        return row;
    }
    let built = geometry::build_parts_measured(d, None, None).and_then(|(parts, gaps)| {
        geometry::check_assembly(d, &parts)?;
        Ok((parts, gaps))
    });
    let (parts, gaps) = match built {
        Ok(b) => b,
        Err(e) => {
            refused(&mut row, "refused-build", e.to_string());
            return row;
        }
    };
    row.outcome = "built";
    row.not_watertight = parts.iter().any(|p| !watertight(&p.mesh.triangles));
    row.gap_eaten = gaps
        .iter()
        .any(|g| g.meshed_gap_mm < 0.8 * g.designed_gap_mm - 1e-12);
    let floor = floor_mm(d) - 1e-9;
    let coated = d.fiber_routing.coated_diameter_mm;
    row.under_floor = gaps
        .iter()
        .any(|g| g.inner.is_none() && 2.0 * g.meshed_gap_mm + coated <= coated)
        || d.module.as_ref().is_some_and(|m| {
            m.pillars.fiber_hole_diameter_mm < floor || m.top_hole_diameter_mm < floor
        })
        || d.array
            .as_ref()
            .is_some_and(|a| a.mold.slit_width_mm < floor);
    let mut kinds = Vec::new();
    let module: Vec<&BuiltPart> = parts
        .iter()
        .filter(|p| p.kind.part().in_module())
        .filter(|p| {
            let first = !kinds.contains(&p.kind);
            kinds.push(p.kind);
            first
        })
        .collect();
    // A press fit (a designed clearance of 0) touches: the meshes' chords may cross
    // by up to the coarser part's chord tolerance, which no slicer resolves.
    let m = d.module.as_ref();
    let press = |a: PartKind, b: PartKind| {
        let fit = |k: PartKind, l: PartKind| (a == k && b == l) || (a == l && b == k);
        m.is_some_and(|m| {
            (fit(PartKind::Cap, PartKind::Core) && m.cap_core_clearance_mm == 0.0)
                || (fit(PartKind::Core, PartKind::Insert) && m.core_insert_clearance_mm == 0.0)
        })
    };
    let allowed = |a: &BuiltPart, b: &BuiltPart| {
        if press(a.kind, b.kind) {
            OVERLAP_MM + a.mesh_tolerance_mm.max(b.mesh_tolerance_mm)
        } else {
            OVERLAP_MM
        }
    };
    if let Some(o) = parts_overlap(&module, allowed) {
        row.overlap = true;
        row.message = o;
    }
    row
}

/// The totals of a run.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Summary {
    /// Scenarios drawn.
    pub scenarios: usize,
    /// Built (exit 0).
    pub built: usize,
    /// Refused by the spec's validation.
    pub refused_spec: usize,
    /// Refused by the build.
    pub refused_build: usize,
    /// Each kind of confidently wrong output: (name, count).
    pub wrong_by_kind: Vec<(String, usize)>,
    /// Scenarios with any confidently wrong output.
    pub confidently_wrong: usize,
    /// Wilson 95 % interval of the confidently wrong share, percent.
    pub confidently_wrong_ci95_percent: (f64, f64),
}

/// Run the study; returns the summary (also written as JSON).
pub fn study(a: &PrintFilesArgs) -> Result<(Vec<Row>, Summary)> {
    let n = if a.quick { 12 } else { a.scenarios };
    let load = |name: &str| fbgforge::design::load(&a.designs.join(name));
    let modules = [
        "clip-on-10mm.toml",
        "clip-on-16mm.toml",
        "clip-on-22mm.toml",
        "clip-on-34mm.toml",
    ]
    .iter()
    .map(|m| load(m))
    .collect::<Result<Vec<_>, _>>()?;
    let array = load("tactile-array-60x80.toml")?;
    std::fs::create_dir_all(&a.out)?;
    let pb = crate::progress::Bar::with("print-files", n as u64);
    let rows: Vec<Row> = (0..n as u64)
        .map(|k| {
            let seed = a.seed + k;
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            let d = if rng.random_bool(0.7) {
                let base = &modules[rng.random_range(0..modules.len())];
                draw_module(&mut rng, base)
            } else {
                draw_array(&mut rng, &array)
            };
            let row = judge(&d, seed);
            if row.wrong() {
                // Each confidently wrong draw's design, to reproduce with the CLI.
                let path = a.out.join(format!("wrong-{seed}.toml"));
                if let Err(e) = fbgforge::output::write_atomic(&path, d.to_toml().as_bytes()) {
                    eprintln!("warning: {e:#}");
                }
            }
            pb.advance(1);
            row
        })
        .collect();
    pb.end();
    let count = |f: fn(&Row) -> bool| rows.iter().filter(|r| f(r)).count();
    let wrong = count(Row::wrong);
    let (lo, hi) = crate::live_starts::wilson(wrong, n);
    let summary = Summary {
        scenarios: n,
        built: count(|r| r.outcome == "built"),
        refused_spec: count(|r| r.outcome == "refused-spec"),
        refused_build: count(|r| r.outcome == "refused-build"),
        wrong_by_kind: vec![
            ("overlap".into(), count(|r| r.overlap)),
            ("under the printer's floor".into(), count(|r| r.under_floor)),
            ("meshed gap under 80 %".into(), count(|r| r.gap_eaten)),
            ("not watertight".into(), count(|r| r.not_watertight)),
            (
                "refusal naming no field".into(),
                count(|r| r.unnamed_refusal),
            ),
        ],
        confidently_wrong: wrong,
        confidently_wrong_ci95_percent: (100.0 * lo, 100.0 * hi),
    };
    Ok((rows, summary))
}

/// Run the study and write `print-files.json` and `print-files.csv`.
pub fn run(a: &PrintFilesArgs) -> Result<()> {
    let (rows, s) = study(a)?;
    std::fs::create_dir_all(&a.out)?;
    let mut csv = String::from("seed,kind,printer,outcome,overlap,under_floor,gap_eaten,not_watertight,unnamed_refusal,message\n");
    for r in &rows {
        csv.push_str(&format!(
            "{},{},{},{},{},{},{},{},{},\"{}\"\n",
            r.seed,
            r.kind,
            r.printer,
            r.outcome,
            r.overlap,
            r.under_floor,
            r.gap_eaten,
            r.not_watertight,
            r.unnamed_refusal,
            r.message.replace('"', "'")
        ));
    }
    fbgforge::output::write_atomic(&a.out.join("print-files.csv"), csv.as_bytes())?;
    fbgforge::output::write_json(
        &a.out.join("print-files.json"),
        &serde_json::json!({"summary": &s, "rows": &rows}),
    )?;
    println!(
        "print-files: {} scenarios: {} built, {} refused by the spec, {} by the build",
        s.scenarios, s.built, s.refused_spec, s.refused_build
    );
    for (what, k) in &s.wrong_by_kind {
        println!("  {what:<28} {k}");
    }
    println!(
        "  confidently wrong: {} of {} (95 % CI {:.1}-{:.1} %)",
        s.confidently_wrong,
        s.scenarios,
        s.confidently_wrong_ci95_percent.0,
        s.confidently_wrong_ci95_percent.1
    );
    Ok(())
}
