//! Running workloads on the model: the cycle-level simulation ([`sim`]), the functional level
//! ([`functional`]) over the stack testbench ([`stack_tb`]), sampling ([`sampling`]), sweeps
//! of configurations over scenes ([`sweep`]), the arms of `sms ablate` ([`ablate`]), the
//! measurements of `sms bench` ([`bench`](mod@bench)), small example waveforms of the stack unit
//! ([`waves`]), the restart-trail walk's traversal steps with short stacks ([`steps`]) and what
//! produced a result, as every report states it ([`provenance`]).

pub mod ablate;
pub mod bench;
pub mod functional;
pub mod memory;
pub mod pool;
pub mod provenance;
pub mod sampling;
pub mod sim;
pub mod stack_tb;
pub mod steps;
pub mod sweep;
pub mod verify;
pub mod walked;
pub mod waves;
