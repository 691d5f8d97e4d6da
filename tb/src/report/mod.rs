//! Reports: `sms bench` ([`bench`](mod@bench)), storage cost ([`cost`]), tables ([`table`]), the sweep's
//! figures ([`figures`]), ablation ([`ablate`]), report folder ([`sweep`]) and SVG charts
//! ([`plot`]).

pub mod ablate;
pub mod bench;
pub mod cost;
pub mod figures;
pub mod plot;
pub mod sweep;
pub mod table;
