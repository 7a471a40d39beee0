// libFuzzer target: the COLMAP .bin model reader (cameras.bin, images.bin,
// points3D.bin from one input split in three). Every malformed input must end
// in InputError, never a crash, a hang or undefined behaviour.

#include <cstdint>

#include "colmap_irav4/io/model_io.h"
#include "colmap_irav4/util/error.h"
#include "tests/fuzz/fuzz_utils.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace colmap_irav4;
  const std::vector<std::string> parts = fuzz::SplitInput(data, size, 3);
  if (parts.size() != 3) return 0;
  fuzz::WriteScratchFile("cameras.bin", parts[0]);
  fuzz::WriteScratchFile("images.bin", parts[1]);
  fuzz::WriteScratchFile("points3D.bin", parts[2]);
  try {
    const Reconstruction model = ReadReconstructionBinary(fuzz::ScratchDir());
    // What was read must be writable again.
    ImagesBinaryBytes(model);
    Points3DBinaryBytes(model);
  } catch (const InputError&) {
  }
  return 0;
}
