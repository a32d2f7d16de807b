# The deployable lookup runtime links none of HDF5, libpng, FreeType, Cairo, deal.II (nor MPI,
# pvdf_plot, pvdf_mapping_format): checked on a program linked with pvdf::lookup alone, both in
# its link command line (what CMake passes the linker, transitive libraries included) and in the
# shared libraries it loads (ldd). The same checks on pvdfkit must find HDF5, which shows that
# they see what they should.
#   cmake -DPROBE=<exe> -DPROBE_LINK=<link.txt> -DCONTROL=<pvdfkit exe> -P check_lookup_links.cmake
set(forbidden "hdf5|libpng|png16|freetype|cairo|deal_ii|deal\\.ii|libmpi|pvdf_plot|pvdf_mapping_format|pvdf_mapping_fem|pvdf_fem")
set(failed FALSE)

function(ldd_of exe out)
  execute_process(COMMAND ldd ${exe} OUTPUT_VARIABLE text RESULT_VARIABLE rc)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "ldd ${exe} failed (${rc})")
  endif()
  string(TOLOWER "${text}" text)
  set(${out} "${text}" PARENT_SCOPE)
endfunction()

file(READ "${PROBE_LINK}" link_line)
string(TOLOWER "${link_line}" link_line)
string(REGEX MATCHALL "${forbidden}" hits "${link_line}")
if(hits)
  list(REMOVE_DUPLICATES hits)
  message(SEND_ERROR "the lookup probe's link line names ${hits}: ${link_line}")
  set(failed TRUE)
endif()
if(NOT link_line MATCHES "libpvdf_lookup\\.a")
  message(SEND_ERROR "the probe's link line does not name libpvdf_lookup.a (is it the right file?): ${link_line}")
  set(failed TRUE)
endif()

ldd_of(${PROBE} probe_libs)
string(REGEX MATCHALL "${forbidden}" hits "${probe_libs}")
if(hits)
  list(REMOVE_DUPLICATES hits)
  message(SEND_ERROR "the lookup probe loads ${hits}:\n${probe_libs}")
  set(failed TRUE)
endif()

ldd_of(${CONTROL} control_libs)
if(NOT control_libs MATCHES "hdf5")
  message(SEND_ERROR "control: ldd does not show HDF5 for pvdfkit, so the check cannot see it:\n${control_libs}")
  set(failed TRUE)
endif()

if(failed)
  message(FATAL_ERROR "lookup runtime link isolation violated")
endif()
string(REGEX MATCHALL "[^ \t\n]+ =>" loaded "${probe_libs}")
message(STATUS "lookup probe loads only: ${loaded}")
