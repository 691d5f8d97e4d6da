//! `sms bench`'s report: the verdict, tables and files (`render`, `tables`) and the plot (`plot`)
//! of the data in [`crate::run::bench::data`].

mod plot;
mod render;
mod tables;
