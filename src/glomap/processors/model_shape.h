// The shape of a registered model that decides what its images can
// determine: how far the viewing directions spread, and whether the cameras
// look down on a block much wider than their height above it, the shape in
// which a bend of the whole block is nearly invisible to the reprojection
// error (issue 14: "doming").
#pragma once

#include "base/reconstruction.h"

namespace glomap {

// Median angle [deg] between the registered images' optical axes and their
// mean direction; 180 without registered images.
double ViewDirectionSpreadDeg(const colmap::Reconstruction& model);

// A block of cameras that all look one way onto a wide area: an aerial
// survey with nadir images is the typical one. Bending such a block onto a
// sphere of radius R changes each image like a radial distortion of
// -height / (2 R), so a model that refines radial distortion without
// position priors can bend (dome) with almost no cost: on the 2,000-image
// synthetic survey (unknown focal length and distortion) converged bundle
// adjustment moved away from the true model to a dome with 0.3 deg of tilt
// at the edges, at a lower cost (AUC@3 100 -> 87.5).
struct NadirBlockShape {
  // ViewDirectionSpreadDeg.
  double view_spread_deg = 180;
  // Angle [deg] between the mean viewing direction and the normal of the
  // plane that best fits the camera centres (least squares); 90 when the
  // cameras look along that plane, as on a street.
  double view_to_plane_normal_deg = 90;
  // Width of the block: twice the standard deviation of the camera centres
  // along the narrower of the plane's two directions [model units].
  double width = 0;
  // Median depth of the observed points in their cameras [model units].
  double height = 0;

  double WidthOverHeight() const { return height > 0 ? width / height : 0; }
};

// Measured on the registered images of `model` and the points they observe.
// Fewer than three registered images give the defaults (not a block).
NadirBlockShape MeasureNadirBlock(const colmap::Reconstruction& model);

}  // namespace glomap
