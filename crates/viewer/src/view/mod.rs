use crate::cli::ViewArgs;
use anyhow::Result;
pub fn run(_args: ViewArgs) -> Result<()> {
    Ok(())
}
