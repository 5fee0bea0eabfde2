//! What the subcommands share, so that none imports another's file: the
//! time grids ([`grid`]) and the messages more than one of them gives
//! ([`report`]).

pub mod grid;
pub mod report;
