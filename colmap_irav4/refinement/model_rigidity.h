#pragma once

#include <vector>

#include "colmap_irav4/scene/reconstruction.h"

namespace colmap_irav4 {

// Whether a model is one rigid piece. Two images are tied when they observe
// at least `min_shared_points` common points of the model. A part of the
// model joined to the rest through one image only (an articulation image of
// the tie graph), or not at all, has a free relative scale about that
// image's centre (and, when not joined at all, a free offset and rotation
// too): bearings from a single camera do not fix how far away the other
// part is. Such a model may be placed arbitrarily wrong while its
// reprojection errors look perfect, so it must not be written as one model.
// Two parts joined at one image are nonetheless one rigid piece when at
// least `min_shared_points` points are each seen by an image of both parts
// other than the joint, over any number of image pairs: each such point's
// rays fix the scale about the joint (ties spread over image pairs of a few
// points each, as where match rates vary, count together).
struct ModelRigidityOptions {
  int min_shared_points = 15;
};

struct ModelRigidity {
  // The 2-connected blocks of the tie graph, each sorted by image id,
  // largest first (ties: smallest id first); an articulation image only in
  // the block it shares the most points with (so the blocks are disjoint);
  // images tied to no other image are left out.
  std::vector<std::vector<image_t>> blocks;
  // Number of blocks of at least min_model_size images.
  int num_large_blocks = 0;
  // The same blocks with every image of each (an articulation image in each
  // block it joins), in the order Tarjan's search closes them; the blocks
  // and their articulation images form a tree per connected part.
  std::vector<std::vector<image_t>> joined_blocks;
};

ModelRigidity AnalyzeModelRigidity(const ModelRigidityOptions& options,
                                   const Reconstruction& reconstruction,
                                   int min_model_size);

// The same rule over points given by their images only (e.g. feature tracks
// not yet triangulated): `point_images[p]` lists the images observing point
// p; images not in `images` are ignored.
ModelRigidity AnalyzeTieRigidity(
    const ModelRigidityOptions& options, const std::vector<image_t>& images,
    const std::vector<std::vector<image_t>>& point_images, int min_model_size);

}  // namespace colmap_irav4
