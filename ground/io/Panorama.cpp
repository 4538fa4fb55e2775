#include "ground/io/Panorama.hpp"

#include <utility>

#include "ground/io/CameraFile.hpp"
#include "ground/io/ImageFile.hpp"

namespace areomap::io {

PanoramaImage loadPanoramaImage(const ImageRef& ref) {
  PanoramaImage out;
  out.stem = ref.stem;
  out.image_path = ref.image_path;
  out.grey = loadImage8(ref.image_path);
  if (!out.grey.isContinuous()) out.grey = out.grey.clone();
  const std::string model_path = ref.model_path.empty() ? ref.image_path : ref.model_path;
  out.model = readCameraModelForImage(model_path, ref.image_path, out.grey.cols, out.grey.rows);
  return out;
}

const PanoramaImage* Panorama::find(const std::string& stem) const {
  int pair = 0;
  bool is_right = false;
  if (!dataset.findStem(stem, pair, is_right)) return nullptr;
  const auto k = static_cast<std::size_t>(pair);
  if (k >= left.size()) return nullptr;
  if (!is_right) return &left[k];
  return right[k] ? &*right[k] : nullptr;
}

Panorama loadPanorama(Dataset dataset) {
  Panorama p;
  p.left.reserve(dataset.pairs.size());
  p.right.reserve(dataset.pairs.size());
  for (const Pair& pair : dataset.pairs) {
    p.left.push_back(loadPanoramaImage(pair.left));
    p.right.push_back(pair.right ? std::optional<PanoramaImage>(loadPanoramaImage(*pair.right))
                                 : std::nullopt);
  }
  p.dataset = std::move(dataset);
  return p;
}

}  // namespace areomap::io
