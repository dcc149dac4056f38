//! The report stage: figures (plotters, SVG or PNG by extension) and,
//! later, the HTML reports. Every output is written atomically.

pub mod batch_plot;
pub mod batch_view;
pub mod html;
pub mod plot;
pub mod table;
pub mod validation_plot;
pub mod views;
