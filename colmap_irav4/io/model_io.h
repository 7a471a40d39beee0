#pragma once

// Reading and writing COLMAP sparse models (cameras, images, points3D), in
// COLMAP's binary (.bin) and text (.txt) formats, byte-compatible with COLMAP
// 3.8. Models written by COLMAP 4.x read too (their cameras/images/points3D
// files have the same layout; rigs and frames files are ignored).
//
// Readers validate everything and throw InputError("<file>: <problem>") on
// bad input: missing or truncated files, unknown camera models, wrong numbers
// of parameters, malformed text lines, duplicate ids, images referencing
// missing cameras, tracks and observations that disagree, any NaN or inf
// value (NonFiniteValueProblem).
//
// Writers write records in increasing id order (COLMAP writes its hash-map
// order, which is not defined). Each file goes to a temporary name in the
// target directory and is renamed only once all files of the model are
// complete, so a failure leaves no partial model behind. A model with a
// NaN or inf value is never written (InputError).

#include <string>

#include "colmap_irav4/scene/reconstruction.h"
#include "colmap_irav4/scene/reconstruction_utils.h"

namespace colmap_irav4 {

// Reads the model in directory `path`: binary if cameras.bin, images.bin and
// points3D.bin exist, else text (cameras.txt, images.txt, points3D.txt).
Reconstruction ReadReconstruction(const std::string& path);
Reconstruction ReadReconstructionBinary(const std::string& path);
Reconstruction ReadReconstructionText(const std::string& path);

// Checks a model built in memory (the Python module's write_model) as the
// readers check files: camera models and their number of parameters, finite
// poses, the images' cameras, tracks against observations. Throws
// InputError("<source>: <problem>").
void CheckReconstruction(const std::string& source,
                         const Reconstruction& reconstruction);

// Whether `path` holds a binary or text model.
bool ExistsBinaryModel(const std::string& path);
bool ExistsTextModel(const std::string& path);

// Writes the model into directory `path` (created if missing); output_type is
// "BIN" or "TXT" (case-insensitive), anything else throws InputError.
void WriteReconstruction(const Reconstruction& reconstruction,
                         const std::string& path,
                         const std::string& output_type = "BIN");
void WriteReconstructionBinary(const Reconstruction& reconstruction,
                               const std::string& path);
void WriteReconstructionText(const Reconstruction& reconstruction,
                             const std::string& path);

// Single files. The readers fill their part of `reconstruction` and check
// references to the parts read before (images need their cameras, points3D
// their images): read cameras, then images, then points3D. The readers of
// points3D check every track against the images' observations.
void ReadCamerasBinary(const std::string& path, Reconstruction* reconstruction);
void ReadImagesBinary(const std::string& path, Reconstruction* reconstruction);
void ReadPoints3DBinary(const std::string& path,
                        Reconstruction* reconstruction);
void ReadCamerasText(const std::string& path, Reconstruction* reconstruction);
void ReadImagesText(const std::string& path, Reconstruction* reconstruction);
void ReadPoints3DText(const std::string& path, Reconstruction* reconstruction);

// The file contents as COLMAP 3.8 writes them (tests compare them).
std::string CamerasBinaryBytes(const Reconstruction& reconstruction);
std::string ImagesBinaryBytes(const Reconstruction& reconstruction);
std::string Points3DBinaryBytes(const Reconstruction& reconstruction);
std::string CamerasTextBytes(const Reconstruction& reconstruction);
std::string ImagesTextBytes(const Reconstruction& reconstruction);
std::string Points3DTextBytes(const Reconstruction& reconstruction);

// Mean number of observations (points2D with a 3D point) per image, as
// COLMAP prints it in images.txt; NumObservations and MeanTrackLength are in
// scene/reconstruction_utils.h.
double MeanObservationsPerImage(const Reconstruction& reconstruction);

// Why an image name cannot be written to images.txt so that it reads back
// (empty, control characters such as a newline, leading or trailing space);
// "" if it can. ImagesTextBytes throws InputError for such a name.
std::string TextImageNameProblem(const std::string& name);

}  // namespace colmap_irav4
