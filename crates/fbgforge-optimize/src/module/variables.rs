//! The continuous design variables (diameter, walls, dome, height): their names on
//! the command line, their values in a module, their default bounds and the user's
//! bound overrides.

use crate::spec::Module;
use serde::Serialize;

/// A continuous design variable.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Hash)]
#[serde(rename_all = "snake_case")]
pub enum Variable {
    /// `module.outer_diameter_mm`.
    OuterDiameterMm,
    /// `module.cap_wall_mm`.
    CapWallMm,
    /// `module.core_wall_mm`.
    CoreWallMm,
    /// `module.dome_height_mm` / outer radius (1 = hemisphere).
    DomeHeightRatio,
    /// `module.overall_height_mm` (otherwise it scales with the diameter).
    OverallHeightMm,
}

impl Variable {
    /// Every variable.
    pub const ALL: [Variable; 5] = [
        Variable::OuterDiameterMm,
        Variable::CapWallMm,
        Variable::CoreWallMm,
        Variable::DomeHeightRatio,
        Variable::OverallHeightMm,
    ];
    /// Varied when the user does not say.
    pub(crate) const DEFAULT: [Variable; 4] = [
        Variable::OuterDiameterMm,
        Variable::CapWallMm,
        Variable::CoreWallMm,
        Variable::DomeHeightRatio,
    ];

    /// Name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Variable::OuterDiameterMm => "outer_diameter_mm",
            Variable::CapWallMm => "cap_wall_mm",
            Variable::CoreWallMm => "core_wall_mm",
            Variable::DomeHeightRatio => "dome_height_ratio",
            Variable::OverallHeightMm => "overall_height_mm",
        }
    }

    /// Parse a comma-separated list, naming an unknown entry and the known ones.
    pub fn parse_list(s: &str) -> anyhow::Result<Vec<Variable>> {
        let mut out = Vec::new();
        for name in s.split(',').map(str::trim).filter(|n| !n.is_empty()) {
            let v = Variable::ALL
                .iter()
                .copied()
                .find(|v| v.name() == name)
                .ok_or_else(|| {
                    let known: Vec<&str> = Variable::ALL.iter().map(|v| v.name()).collect();
                    anyhow::anyhow!(
                        "unknown variable `{name}` in ModuleSettings.vary; known: {}",
                        known.join(", ")
                    )
                })?;
            if out.contains(&v) {
                anyhow::bail!("variable `{name}` is listed twice in ModuleSettings.vary");
            }
            out.push(v);
        }
        anyhow::ensure!(!out.is_empty(), "ModuleSettings.vary lists no variable");
        Ok(out)
    }

    /// The variable's value in a module.
    pub fn value(self, m: &Module) -> f64 {
        match self {
            Variable::OuterDiameterMm => m.outer_diameter_mm,
            Variable::CapWallMm => m.cap_wall_mm,
            Variable::CoreWallMm => m.core_wall_mm,
            Variable::DomeHeightRatio => m.dome_height_mm / (m.outer_diameter_mm / 2.0),
            Variable::OverallHeightMm => m.overall_height_mm,
        }
    }

    /// Default search range given the start module and the printer's minimum wall.
    /// The diameter spans the paper's scripted 10–22 mm, widened to hold the start.
    pub(crate) fn default_bounds(self, m: &Module, min_wall_mm: f64) -> (f64, f64) {
        let v = self.value(m);
        match self {
            Variable::OuterDiameterMm => (v.min(10.0), v.max(22.0)),
            Variable::CapWallMm | Variable::CoreWallMm => (min_wall_mm, v.max(3.0)),
            Variable::DomeHeightRatio => (v.min(0.3), 1.0),
            Variable::OverallHeightMm => (0.6 * v, 1.4 * v),
        }
    }
}

/// Parse `name=lo:hi` bound overrides.
pub fn parse_bounds(s: &str) -> anyhow::Result<Vec<(Variable, f64, f64)>> {
    let mut out = Vec::new();
    for item in s.split(',').map(str::trim).filter(|n| !n.is_empty()) {
        let (name, range) = item.split_once('=').ok_or_else(|| {
            anyhow::anyhow!("bound `{item}`: expected NAME=LO:HI, e.g. outer_diameter_mm=10:22")
        })?;
        let v = Variable::parse_list(name)?[0];
        let (lo, hi) = range
            .split_once(':')
            .ok_or_else(|| anyhow::anyhow!("bound `{item}`: expected NAME=LO:HI"))?;
        let num = |t: &str| -> anyhow::Result<f64> {
            let x: f64 = t
                .trim()
                .parse()
                .map_err(|_| anyhow::anyhow!("bound `{item}`: `{t}` is not a number"))?;
            anyhow::ensure!(x.is_finite(), "bound `{item}`: `{t}` is not finite");
            Ok(x)
        };
        out.push((v, num(lo)?, num(hi)?));
    }
    Ok(out)
}
