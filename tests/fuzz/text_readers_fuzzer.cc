// libFuzzer target: the text readers. The first byte picks the reader:
// relative poses (view_graph's format), absolute rotations, 1DSfM EGs.txt,
// list.txt, cc.txt and Bundler gt_bundle.out, Strecha .camera, and the COLMAP
// TXT model (the rest split in three files). Every malformed input must end
// in InputError.

#include <cstdint>

#include "colmap_irav4/eval/onedsfm.h"
#include "colmap_irav4/eval/relpose_io.h"
#include "colmap_irav4/eval/strecha_gt.h"
#include "colmap_irav4/io/model_io.h"
#include "colmap_irav4/util/error.h"
#include "tests/fuzz/fuzz_utils.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace colmap_irav4;
  if (size < 1) return 0;
  const int reader = data[0] % 8;
  const std::string text(reinterpret_cast<const char*>(data + 1), size - 1);
  try {
    switch (reader) {
      case 0:
        ReadRelativePoses(fuzz::WriteScratchFile("relpose.txt", text));
        break;
      case 1:
        ReadAbsoluteRotations(fuzz::WriteScratchFile("rotations.txt", text));
        break;
      case 2:
        ReadOneDsfmEdges(fuzz::WriteScratchFile("EGs.txt", text), 50);
        break;
      case 3:
        ReadOneDsfmList(fuzz::WriteScratchFile("list.txt", text));
        ReadOneDsfmComponent(fuzz::WriteScratchFile("cc.txt", text), 50);
        break;
      case 4:
        ReadBundlerFile(fuzz::WriteScratchFile("gt_bundle.out", text));
        break;
      case 5:
        ReadStrechaCamera(fuzz::WriteScratchFile("0000.jpg.camera", text));
        break;
      default: {
        const std::vector<std::string> parts =
            fuzz::SplitInput(data + 1, size - 1, 3);
        if (parts.size() != 3) return 0;
        fuzz::WriteScratchFile("cameras.txt", parts[0]);
        fuzz::WriteScratchFile("images.txt", parts[1]);
        fuzz::WriteScratchFile("points3D.txt", parts[2]);
        const Reconstruction model = ReadReconstructionText(fuzz::ScratchDir());
        CamerasTextBytes(model);
        Points3DTextBytes(model);
        break;
      }
    }
  } catch (const InputError&) {
  }
  return 0;
}
