//! What the balloon knows of the image: the structure's intensity model from the seed alone
//! (`seed_statistics`, with CT's calibrated levels from `hounsfield`), and the rule that says
//! where the balloon may go and how fast it inflates there (`border`, which stops it at thin
//! bright layers too: `thin_layer`), within the region of interest (`region`).

pub mod border;
pub(in crate::balloon) mod hounsfield;
pub mod region;
pub mod seed_statistics;
pub(in crate::balloon) mod thin_layer;
