//! What one figure of the report is: its table, notes, JSON and chart. The sweep's figures
//! ([`super::figures`]), the thread-cycle breakdown ([`super::breakdown`]) and the ablation
//! ([`super::ablate`]) each make one or more.

use serde_json::Value;

use super::plot::Chart;
use super::table::Table;

/// One figure of the report.
#[derive(Clone, Debug)]
pub struct Figure {
    /// File stem in the report folder.
    pub name: &'static str,
    pub title: String,
    /// What the figure shows and how its numbers were computed.
    pub note: String,
    pub table: Table,
    /// The figure's numbers scene by scene, when `table` does not already give them per scene.
    pub per_scene: Option<Table>,
    pub json: Value,
    pub chart: Chart,
}
