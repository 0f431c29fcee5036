// ParaView collection (.pvd) of time steps, rewritten atomically after every added step.
#include <cmath>
#include <ostream>

#include "shatter/core/file_io.h"
#include "shatter/mesh/io/mesh_io.h"
#include "shatter/mesh/io/mesh_io_util.h"
#include "shatter/mesh/io/xml_lite.h"

namespace shatter {

Result<void> PvdSeries::add(double time, const std::string& file) {
  if (!std::isfinite(time)) return make_error("PvdSeries::add: time " + std::to_string(time) + " is not finite");
  entries_.emplace_back(time, file);
  std::string text =
      "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n  "
      "<Collection>\n";
  for (const auto& [t, f] : entries_) {
    text += "    <DataSet timestep=\"";
    io::append_double(text, t);
    text += "\" group=\"\" part=\"0\" file=\"" + io::xml_escape(f) + "\"/>\n";
  }
  text += "  </Collection>\n</VTKFile>\n";
  Result<void> r = write_file_atomic(path_, text);
  if (!r) entries_.pop_back();
  return r;
}

}  // namespace shatter
