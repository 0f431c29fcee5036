// A material in a JSON input file (case and scene files; internal): a preset name, or an object of
// values with an optional "preset" to start from (docs/static_case.md#material).
#pragma once

#include "shatter/core/error.h"
#include "shatter/core/json_reader.h"
#include "shatter/fem/material.h"

namespace shatter {

/// The material at `where`, validated; errors name the file, the JSON path and what was expected.
Result<Material> read_material_json(const json_input::Json& value, const json_input::Where& where);

}  // namespace shatter
