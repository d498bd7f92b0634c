// PCD point clouds through PCL (ascii, binary, binary_compressed).
#include "fuzz_common.h"
#include "ttp/inspect/point_io.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return ttp::fuzz::Run([&] {
    ttp::inspect::ParsePointCloud({reinterpret_cast<const char*>(data), size},
                                  "fuzz.pcd");
  });
}
