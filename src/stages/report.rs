//! `report`: the self-contained HTML report of everything in the output
//! directory (`report.html`); every number comes from the stage outputs.

use crate::error::Result;
use crate::pipeline::{params, RunContext, StageDecl};
use crate::report::{write_report, ReportSettings};

pub fn run(stage: &StageDecl, ctx: &mut RunContext) -> Result<()> {
    let settings: ReportSettings = params(stage)?;
    write_report(&ctx.out_dir, &settings)?;
    Ok(())
}
