#include "gdal_support.hpp"

#include <cpl_conv.h>

#include <mutex>

namespace talus::io::gdal {

void register_drivers() {
  static std::once_flag once;
  std::call_once(once, [] { GDALAllRegister(); });
}

Quiet::Quiet() {
  register_drivers();
  CPLPushErrorHandler(CPLQuietErrorHandler);
  CPLErrorReset();
}

Quiet::~Quiet() { CPLPopErrorHandler(); }

std::string Quiet::last_message() {
  const char* msg = CPLGetLastErrorMsg();
  return msg && *msg ? std::string(" (") + msg + ")" : std::string();
}

std::string take_string(char* text) {
  std::string out = text ? text : "";
  CPLFree(text);
  return out;
}

std::string name_of(OGRSpatialReferenceH srs) {
  const char* name = OSRGetName(srs);
  std::string out = name && *name ? name : "unnamed";
  const char* authority = OSRGetAuthorityName(srs, nullptr);
  const char* code = OSRGetAuthorityCode(srs, nullptr);
  if (authority && code) out += std::string(" (") + authority + ":" + code + ")";
  return out;
}

SrsPtr identified(OGRSpatialReferenceH source) {
  SrsPtr srs(OSRClone(source));
  OSRSetAxisMappingStrategy(srs.get(), OAMS_TRADITIONAL_GIS_ORDER);
  if (OSRGetAuthorityCode(srs.get(), nullptr)) return srs;
  // A definition without a code (an ESRI .prj): the registered CRS it matches, if GDAL
  // is sure of one (confidence >= 90 of 100).
  int count = 0;
  int* confidence = nullptr;
  OGRSpatialReferenceH* matches = OSRFindMatches(srs.get(), nullptr, &count, &confidence);
  if (count > 0 && confidence[0] >= 90) {
    SrsPtr best(OSRClone(matches[0]));
    OSRSetAxisMappingStrategy(best.get(), OAMS_TRADITIONAL_GIS_ORDER);
    srs = std::move(best);
  }
  OSRFreeSRSArray(matches);
  CPLFree(confidence);
  return srs;
}

SrsPtr parse_srs(const std::string& text) {
  SrsPtr srs(OSRNewSpatialReference(nullptr));
  if (OSRSetFromUserInput(srs.get(), text.c_str()) != OGRERR_NONE) return nullptr;
  return identified(srs.get());
}

}  // namespace talus::io::gdal
