//! `report`: the self-contained HTML report of everything in the output
//! directory (`report.html`); every number comes from the stage outputs.

use crate::error::Result;
use crate::pipeline::{Product, RunContext, Stage, StageKind, StageSource};
use crate::report::{write_report, ReportSettings, REPORT_FILE};

pub const KIND: StageKind = StageKind {
    kind: "report",
    needs: &[],
    provides: None,
    reads_all_earlier: true,
    build,
};

fn build(src: &StageSource) -> Result<Box<dyn Stage>> {
    Ok(Box::new(Report {
        settings: src.params()?,
    }))
}

struct Report {
    settings: ReportSettings,
}

impl Stage for Report {
    fn outputs(&self) -> Vec<String> {
        vec![REPORT_FILE.into()]
    }
    fn run(&self, ctx: &mut RunContext) -> Result<Option<Product>> {
        write_report(&ctx.out_dir, &self.settings)?;
        Ok(None)
    }
}
