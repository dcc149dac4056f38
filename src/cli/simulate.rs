//! `stickslip simulate`: one forcing frequency, exact engine.

use super::ModelArgs;
use clap::Args;

/// Arguments of `stickslip simulate`.
#[derive(Debug, Args)]
pub struct SimulateArgs {
    /// Model options.
    #[command(flatten)]
    pub model: ModelArgs,
    /// Forcing frequency ratio η = Ω·sqrt(M2/K2).
    #[arg(long)]
    pub eta: f64,
}

/// Runs `simulate`.
pub fn run(args: SimulateArgs) -> crate::Result<()> {
    let _model = args.model.model()?;
    crate::model::validate_eta(args.eta)?;
    Err(crate::sim::SimError::Unsupported("simulate: engine not built yet".into()).into())
}
