# <torch/torch.h> as a precompiled header, built once and reused by every target
# whose sources include LibTorch. Parsing it costs about three quarters of a
# typical translation unit here (~12 s of ~16 s on one core); loading the
# precompiled header costs about a third of that.
#
# GCC uses a precompiled header only with the position-independence setting and
# the command-line macros it was made with, so two small object libraries carry
# them, with LibTorch's flags and nothing else: msspr_torch_pch_pic (-fPIC) for
# shared and position-independent libraries (msspr_core too), msspr_torch_pch_exe
# (the compiler's default) for executables and other libraries.
#
#   msspr_torch_pch(target ...)   # after the targets are defined
#
# -DMSSPR_PRECOMPILE_TORCH=OFF turns it off (with ccache, or a compiler that
# handles precompiled headers badly); nothing else changes.
include_guard(GLOBAL)

option(MSSPR_PRECOMPILE_TORCH "Precompile <torch/torch.h> once for every target that includes it" ON)

# Makes the two headers' hosts; called once, where Torch was found.
function(msspr_torch_pch_hosts)
  if(NOT MSSPR_PRECOMPILE_TORCH)
    return()
  endif()
  foreach(host msspr_torch_pch_pic msspr_torch_pch_exe)
    add_library(${host} OBJECT ${CMAKE_CURRENT_FUNCTION_LIST_DIR}/torch_pch_host.cc)
    target_link_libraries(${host} PRIVATE ${TORCH_LIBRARIES})
    target_compile_features(${host} PRIVATE cxx_std_17)
    target_precompile_headers(${host} PRIVATE <torch/torch.h>)
  endforeach()
  set_target_properties(msspr_torch_pch_pic PROPERTIES POSITION_INDEPENDENT_CODE ON)
endfunction()

function(msspr_torch_pch)
  if(NOT MSSPR_PRECOMPILE_TORCH OR NOT TARGET msspr_torch_pch_exe)
    return()
  endif()
  foreach(target ${ARGN})
    get_target_property(type ${target} TYPE)
    get_target_property(pic ${target} POSITION_INDEPENDENT_CODE)
    if(type STREQUAL "SHARED_LIBRARY" OR type STREQUAL "MODULE_LIBRARY"
       OR (NOT type STREQUAL "EXECUTABLE" AND pic))
      target_precompile_headers(${target} REUSE_FROM msspr_torch_pch_pic)
    else()
      target_precompile_headers(${target} REUSE_FROM msspr_torch_pch_exe)
    endif()
  endforeach()
endfunction()
