#pragma once
// What every radiosity stage shares: the one error type for input that cannot be baked, and
// the one progress callback. bake.h states the stages' common principles.

#include <cstddef>
#include <functional>
#include <stdexcept>
#include <string_view>

namespace abrad::radiosity {

/// Settings or a scene that cannot be baked (an option out of range, a setting the chosen
/// mode does not use, a scene without lights...): the caller's bad input (exit status 2).
/// Thrown by every stage, the field error and the point queries; the message names the option
/// or the scene element. (The building blocks under the stages, Hemicube, shoot and
/// mesh_regions, throw std::invalid_argument, a std::logic_error, for a broken precondition:
/// the stages validate first, so that is a bug of the caller, like a failed ABRAD_CHECK.)
class InputError : public std::runtime_error {
  public:
    using std::runtime_error::runtime_error;
};

/// Progress of long work: a stage label and `done` of `total` units (`total` 0 when the end
/// is not known in advance, as for shots until convergence). Called from the thread that runs
/// the stage, or from a worker thread under the stage's lock; it must be cheap.
using ProgressFn = std::function<void(std::string_view stage, std::size_t done, std::size_t total)>;

}  // namespace abrad::radiosity
