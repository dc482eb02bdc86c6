//! The skeleton core: keypoints in, bone rotations on the 53-bone rig out, and back.
//!
//! - [`rig`]: the 53 bones, their parents, rest geometry and degree-of-freedom classes;
//!   [`character`]: a body's proportions on that rig.
//! - [`layout`]: keypoint layouts (COCO-WholeBody-133, NTU-25, H36M-17, …) and how their joints
//!   bind to the rig's landmarks; [`pose`]: keypoint sequences as sources give them.
//! - [`convert`]: the solver — keypoints → local bone rotations (the paper's rotation-oriented
//!   motion representation); [`fk`]: forward kinematics, rotations → joint positions.
//! - [`resample`]: rotations at a new frame rate, on the rotation group; [`eval`]: how faithfully
//!   a conversion reproduces its input.
//! - [`frames`]: the coordinate conventions (Z up, faces +Y) and the one place each source's
//!   axes are converted; [`ground`]: camera-frame estimates stood on the ground;
//!   [`lengths`]: how much measured bone lengths vary, and fixing them by two-bone IK;
//!   [`geom`]: rotation helpers shared by all of the above.
//! - [`describe`]: the rig and the layouts as tables and JSON, for people (`autoact rig`,
//!   `autoact layouts`).

pub mod character;
pub mod convert;
pub mod describe;
pub mod eval;
pub mod fk;
pub mod frames;
pub mod geom;
pub mod ground;
pub mod layout;
pub mod lengths;
pub mod pose;
pub mod resample;
pub mod rig;
