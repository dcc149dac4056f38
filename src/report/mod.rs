//! The report stage: figures (plotters, SVG or PNG by extension) and the
//! HTML reports (minijinja, everything from a log auto-escaped). Every
//! output is written atomically.

pub mod batch_plot;
pub mod batch_view;
pub mod characteristic_plot;
pub mod frc_json;
pub mod html;
pub mod plot;
pub mod sections;
pub mod table;
pub mod validation_plot;
pub mod views;
