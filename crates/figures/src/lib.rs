//! flexstage figures: what the stages and the report draw, with no knowledge of a run folder.
//!
//! * [`plot`]: line and scatter figures as SVG (plotters, a bundled font, text ≥ 11 px at
//!   100 %), reduced for display by [`simplify`];
//! * [`image`]: density fields as grey-scale PNG (Figure 4 of Actuators 2022, 11(7), 179)
//!   and back;
//! * [`mode_shape`]: the mode shapes of a design drawn deformed, as PNG;
//! * [`vtk`]: quadrilateral meshes with point and cell data as VTU documents for ParaView;
//! * [`cloud`]: a point cloud summarized by its mean, covariance ellipse and convex hull.
//!
//! Every function returns bytes or text; where they are stored is the caller's business
//! (`flexstage-run` names the files of a run folder).

pub mod cloud;
pub mod image;
pub mod mode_shape;
pub mod plot;
pub mod simplify;
pub mod vtk;
