// Overloaded: a set of lambdas as one visitor, for std::visit over a message variant with one
// handler per alternative and no generic fallback, so that a new alternative fails to compile
// until every visit says what it does with it.
#pragma once

namespace scaratwin {

template <class... Fs>
struct Overloaded : Fs... {
  using Fs::operator()...;
};
template <class... Fs>
Overloaded(Fs...) -> Overloaded<Fs...>;

}  // namespace scaratwin
