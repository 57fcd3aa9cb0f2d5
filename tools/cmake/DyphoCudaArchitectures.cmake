# Which GPU architectures the CUDA kernels are compiled for.
#
#   DYPHO_CUDA_ARCHITECTURES=auto (default)
#     - a GPU is visible at configure time (nvidia-smi lists one): `native`,
#       the architectures of the GPUs present (CMake >= 3.24; older CMake gets
#       the compute capability nvidia-smi reports, e.g. 90);
#     - else the portable list 75-real;80-real;86-real;89-real;90: machine code
#       (SASS) for Turing (7.5), Ampere (8.0, 8.6), Ada (8.9) and Hopper (9.0),
#       plus PTX of 9.0, which the driver compiles just in time for newer cards
#       (Blackwell and later; the first launch there is slower).
#   DYPHO_CUDA_ARCHITECTURES=<list>  used as given (e.g. 86, "native", "80;90").
#   CMAKE_CUDA_ARCHITECTURES set by the caller wins over both.
#
# The choice is made before enable_language(CUDA); it is printed at configure.
set(DYPHO_CUDA_PORTABLE_ARCHITECTURES "75-real;80-real;86-real;89-real;90")

# dypho_pick_cuda_architectures(<out> <requested> <nvidia_smi or empty> <cmake version>)
# Pure function (also run by tools/cmake/test_cuda_architectures.cmake).
function(dypho_pick_cuda_architectures out requested nvidia_smi cmake_version)
  if(NOT requested STREQUAL "auto")
    set(${out} "${requested}" PARENT_SCOPE)
    set(${out}_REASON "DYPHO_CUDA_ARCHITECTURES=${requested}" PARENT_SCOPE)
    return()
  endif()
  set(cap "")
  if(nvidia_smi)
    execute_process(COMMAND ${nvidia_smi} --query-gpu=compute_cap --format=csv,noheader
      RESULT_VARIABLE rc OUTPUT_VARIABLE caps ERROR_QUIET TIMEOUT 20)
    if(rc EQUAL 0)
      string(REGEX MATCH "[0-9]+\\.[0-9]+" cap "${caps}")
    endif()
  endif()
  if(cap)
    if(cmake_version VERSION_GREATER_EQUAL 3.24)
      set(${out} "native" PARENT_SCOPE)
    else()
      string(REPLACE "." "" cap_digits "${cap}")
      set(${out} "${cap_digits}" PARENT_SCOPE)
    endif()
    set(${out}_REASON "a GPU of compute capability ${cap} is visible" PARENT_SCOPE)
  else()
    set(${out} "${DYPHO_CUDA_PORTABLE_ARCHITECTURES}" PARENT_SCOPE)
    set(${out}_REASON "no GPU visible at configure time: portable list" PARENT_SCOPE)
  endif()
endfunction()

if(NOT CMAKE_SCRIPT_MODE_FILE)
  set(DYPHO_CUDA_ARCHITECTURES "auto" CACHE STRING
    "CUDA architectures: auto (native with a visible GPU, else 75-real;80-real;86-real;89-real;90) or a CMake list")
  if(DEFINED CMAKE_CUDA_ARCHITECTURES)
    message(STATUS "dypho: CUDA architectures ${CMAKE_CUDA_ARCHITECTURES} (CMAKE_CUDA_ARCHITECTURES)")
  else()
    find_program(DYPHO_NVIDIA_SMI nvidia-smi)
    set(smi "")
    if(DYPHO_NVIDIA_SMI)
      set(smi "${DYPHO_NVIDIA_SMI}")
    endif()
    dypho_pick_cuda_architectures(archs "${DYPHO_CUDA_ARCHITECTURES}" "${smi}" "${CMAKE_VERSION}")
    # Not cached: a later configure on a machine with a GPU picks again.
    set(CMAKE_CUDA_ARCHITECTURES "${archs}")
    message(STATUS "dypho: CUDA architectures ${archs} (${archs_REASON})")
  endif()
endif()
