# wj_set_warnings(target): the project's warning set, applied to project code only
# (third-party headers are included as SYSTEM by their imported targets).
function(wj_set_warnings target)
  target_compile_options(${target} PRIVATE
    -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor -Wold-style-cast -Wcast-align
    -Wunused -Woverloaded-virtual -Wnull-dereference -Wdouble-promotion -Wformat=2
    -Wimplicit-fallthrough)
endfunction()

# wj_use_cxx17(target): Simbody 3.7's headers do not compile as C++20 with GCC 12, so the
# translation units that include them are built as C++17 behind project headers.
function(wj_use_cxx17 target)
  set_target_properties(${target} PROPERTIES CXX_STANDARD 17)
endfunction()
