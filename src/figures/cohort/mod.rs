//! Cohort figures (issue 19 point 3): what `unfold cohort` draws from the
//! tables and images it wrote. Like the single-subject figures, pure
//! functions from numbers to named [`Figure`](super::Figure)s; the command
//! line reads the files and writes the PNGs (`OUT/cohort/figures/`).
//!
//! One file per figure family: box plots ([`box_plot`]; the placenta
//! distortions per template of the placenta paper's Fig. 7 and the mitral
//! energies open against closed use it: [`distortion`], [`energies`]), a
//! measurement against a covariate with its least-squares line
//! ([`scatter`]), the cohort mean, standard deviation and a subject's
//! z-score bull's-eyes ([`bullseyes`]), the mid-depth slices of the placenta
//! mean and standard deviation images ([`slices`]), a group comparison's
//! statistic with its significant region outlined ([`statistic`]); the axes, ticks and
//! title band they share are [`axes`].

pub mod axes;
pub mod box_plot;
pub mod bullseyes;
pub mod distortion;
pub mod energies;
pub mod scatter;
pub mod slices;
pub mod statistic;
