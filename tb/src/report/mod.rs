//! Reports: `sms bench` ([`bench`](mod@bench)), the thread-cycle breakdown ([`breakdown`]),
//! storage cost ([`cost`]), stack depth ([`depth`](mod@depth)), tables ([`table`]), what a
//! figure is ([`figure`]), the sweep's figures ([`figures`]), the ablation's figure
//! ([`ablate`]), report folder ([`sweep`]), SVG charts ([`plot`]) and their layout check
//! ([`layout`]).

pub mod ablate;
pub mod bench;
pub mod breakdown;
pub mod cost;
pub mod depth;
pub mod figure;
pub mod figures;
pub mod layout;
pub mod plot;
pub mod restart;
pub mod sweep;
pub mod table;
