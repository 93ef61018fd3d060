//! Contact detection: the cell index and the half Verlet list (`verlet_list`), with the
//! compressed-row helpers they share (`compressed_rows`).
pub mod compressed_rows;
pub mod verlet_list;
