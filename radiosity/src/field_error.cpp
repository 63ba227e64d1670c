// PLACEHOLDER: being written.
#include "abrad/radiosity/field_error.h"
#include <stdexcept>
namespace abrad::radiosity {
FieldError field_error(const visdb::Scene&, const visdb::BakeMesh&, const IrradianceFn&, const FieldErrorOptions&) {
    throw std::logic_error("field_error: not written yet");
}
}  // namespace abrad::radiosity
