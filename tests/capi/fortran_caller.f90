! A Fortran program on libmdr_c through ISO_C_BINDING (the interfaces below are what a Fortran
! code declares to use the library). It prints what tests/capi/service_reference.cc writes for
! the service (reference.txt), which the test compares byte for byte.
!
!   fortran_caller REFERENCE_DIR SCENE_FILE
!
! The contact is created from the YAML scene file's text; after the history it is restored from
! the service's snapshot (snapshot.pb) and repeats the second part.
module mdr
  use, intrinsic :: iso_c_binding
  implicit none

  integer(c_int), parameter :: MDR_OK = 0, MDR_OUT_OF_RANGE = 11, MDR_ROUTE_BOTH = 1

  ! mdr_state of mdr.h: 10 doubles, then 2 uint64_t.
  type, bind(c) :: mdr_state
    real(c_double) :: depth, tangential_displacement, contact_radius, normal_force, &
                      tangential_force, dissipated_energy, friction_limit, &
                      actuator_displacement, actuator_depth, last_step_dissipation
    integer(c_int64_t) :: applied_steps, memory_vertices
  end type

  interface
    integer(c_int) function mdr_version() bind(c)
      import :: c_int
    end function
    integer(c_int) function mdr_contact_create_from_text(text, name, out) bind(c)
      import :: c_int, c_char, c_ptr
      character(kind=c_char), intent(in) :: text(*), name(*)
      type(c_ptr), intent(out) :: out
    end function
    integer(c_int) function mdr_contact_restore(snapshot, size, out) bind(c)
      import :: c_int, c_size_t, c_ptr, c_int8_t
      integer(c_int8_t), intent(in) :: snapshot(*)
      integer(c_size_t), value :: size
      type(c_ptr), intent(out) :: out
    end function
    subroutine mdr_contact_destroy(contact) bind(c)
      import :: c_ptr
      type(c_ptr), value :: contact
    end subroutine
    integer(c_int) function mdr_contact_step(contact, normal_control, normal_value, &
                                             tangential_control, tangential_value, report) bind(c)
      import :: c_int, c_double, c_ptr
      type(c_ptr), value :: contact, report
      integer(c_int), value :: normal_control, tangential_control
      real(c_double), value :: normal_value, tangential_value
    end function
    integer(c_int) function mdr_contact_state(contact, out) bind(c)
      import :: c_int, c_ptr, mdr_state
      type(c_ptr), value :: contact
      type(mdr_state), intent(out) :: out
    end function
    integer(c_int) function mdr_contact_stiffness(contact, positive, negative) bind(c)
      import :: c_int, c_ptr, c_double
      type(c_ptr), value :: contact
      real(c_double), intent(out) :: positive, negative
    end function
    integer(c_int) function mdr_contact_jager_weights(contact, r_begin, r_end, weight, capacity, &
                                                      count, edge_weight) bind(c)
      import :: c_int, c_ptr, c_double, c_size_t
      type(c_ptr), value :: contact
      real(c_double), intent(out) :: r_begin(*), r_end(*), weight(*), edge_weight
      integer(c_size_t), value :: capacity
      integer(c_size_t), intent(out) :: count
    end function
    integer(c_int) function mdr_contact_tractions(contact, radii, n, route, tangential, &
                                                  tangential_error, normal, normal_error, &
                                                  capacity) bind(c)
      import :: c_int, c_ptr, c_double, c_size_t
      type(c_ptr), value :: contact
      real(c_double), intent(in) :: radii(*)
      integer(c_size_t), value :: n, capacity
      integer(c_int), value :: route
      real(c_double), intent(out) :: tangential(*), tangential_error(*), normal(*), &
                                     normal_error(*)
    end function
    integer(c_int) function mdr_contact_slip_intervals(contact, r_begin, r_end, direction, &
                                                       capacity, count) bind(c)
      import :: c_int, c_ptr, c_double, c_size_t, c_int32_t
      type(c_ptr), value :: contact
      real(c_double), intent(out) :: r_begin(*), r_end(*)
      integer(c_int32_t), intent(out) :: direction(*)
      integer(c_size_t), value :: capacity
      integer(c_size_t), intent(out) :: count
    end function
    type(c_ptr) function mdr_last_error_message() bind(c)
      import :: c_ptr
    end function
  end interface

contains

  ! The last error's message as a Fortran string.
  function last_error() result(message)
    character(len=:), allocatable :: message
    character(kind=c_char), pointer :: chars(:)
    integer :: n
    interface
      integer(c_size_t) function strlen(s) bind(c)
        import :: c_size_t, c_ptr
        type(c_ptr), value :: s
      end function
    end interface
    n = int(strlen(mdr_last_error_message()))
    call c_f_pointer(mdr_last_error_message(), chars, [n])
    allocate(character(len=n) :: message)
    message = transfer(chars, message)
  end function
end module

program fortran_caller
  use, intrinsic :: iso_c_binding
  use, intrinsic :: iso_fortran_env, only: int64, real64, error_unit
  use mdr
  implicit none

  integer, parameter :: restore_at = 100, max_steps = 4096, max_intervals = 4096
  integer(c_int) :: normal_control(max_steps), tangential_control(max_steps)
  real(c_double) :: normal_value(max_steps), tangential_value(max_steps)
  character(len=4096) :: dir, scene_path
  character(len=:), allocatable :: scene_text
  integer(c_int8_t), allocatable :: snapshot(:)
  type(c_ptr) :: contact
  integer :: count

  call get_command_argument(1, dir)
  call get_command_argument(2, scene_path)
  if (mdr_version() /= 1) stop 'libmdr_c: interface version is not 1'
  call read_history(trim(dir)//'/history.txt', count)
  scene_text = read_text(trim(scene_path))
  call check(mdr_contact_create_from_text(scene_text//c_null_char, &
                                          trim(scene_path)//c_null_char, contact), 'create')
  call run(1, count)
  call mdr_contact_destroy(contact)
  snapshot = read_bytes(trim(dir)//'/snapshot.pb')
  call check(mdr_contact_restore(snapshot, int(size(snapshot), c_size_t), contact), 'restore')
  call run(restore_at + 1, count)
  call print_finals()
  call mdr_contact_destroy(contact)

contains

  subroutine check(status, what)
    integer(c_int), intent(in) :: status
    character(len=*), intent(in) :: what
    if (status /= MDR_OK) then
      write(error_unit, '(A,": ",A)') what, last_error()
      error stop 1
    end if
  end subroutine

  function hex(x) result(text)
    real(c_double), intent(in) :: x
    character(len=17) :: text
    write(text, '(1X,Z16.16)') transfer(x, 0_int64)
  end function

  function from_hex(text) result(x)
    character(len=*), intent(in) :: text
    real(c_double) :: x
    integer(int64) :: bits
    read(text, '(Z16)') bits
    x = transfer(bits, x)
  end function

  subroutine read_history(path, n)
    character(len=*), intent(in) :: path
    integer, intent(out) :: n
    character(len=16) :: normal, tangential
    integer :: unit, status
    open(newunit=unit, file=path, status='old', action='read')
    n = 0
    do
      read(unit, *, iostat=status) normal_control(n + 1), normal, tangential_control(n + 1), &
                                   tangential
      if (status /= 0) exit
      n = n + 1
      normal_value(n) = from_hex(normal)
      tangential_value(n) = from_hex(tangential)
    end do
    close(unit)
  end subroutine

  function read_bytes(path) result(bytes)
    character(len=*), intent(in) :: path
    integer(c_int8_t), allocatable :: bytes(:)
    integer :: unit, length
    open(newunit=unit, file=path, access='stream', form='unformatted', status='old')
    inquire(unit=unit, size=length)
    allocate(bytes(length))
    read(unit) bytes
    close(unit)
  end function

  function read_text(path) result(text)
    character(len=*), intent(in) :: path
    character(len=:), allocatable :: text
    integer :: unit, length
    open(newunit=unit, file=path, access='stream', form='unformatted', status='old')
    inquire(unit=unit, size=length)
    allocate(character(len=length) :: text)
    read(unit) text
    close(unit)
  end function

  subroutine run(first, last)
    integer, intent(in) :: first, last
    type(mdr_state) :: state
    integer :: i
    do i = first, last
      call check(mdr_contact_step(contact, normal_control(i), normal_value(i), &
                                  tangential_control(i), tangential_value(i), c_null_ptr), 'step')
      call check(mdr_contact_state(contact, state), 'state')
      write(*, '(A,6A17)') 'S', hex(state%depth), hex(state%tangential_displacement), &
          hex(state%contact_radius), hex(state%normal_force), hex(state%tangential_force), &
          hex(state%dissipated_energy)
    end do
  end subroutine

  subroutine print_finals()
    type(mdr_state) :: state
    real(c_double) :: positive, negative, edge, radii(8), tau(8), tau_error(8), p(8), p_error(8)
    real(c_double) :: r_begin(max_intervals), r_end(max_intervals), weight(max_intervals)
    integer(c_int32_t) :: direction(max_intervals)
    integer(c_size_t) :: n, i
    integer :: k
    call check(mdr_contact_stiffness(contact, positive, negative), 'stiffness')
    write(*, '(A,2A17)') 'K', hex(positive), hex(negative)
    call check(mdr_contact_jager_weights(contact, r_begin, r_end, weight, &
                                         int(max_intervals, c_size_t), n, edge), 'jager_weights')
    write(*, '(A,I0,A17)') 'J ', n, hex(edge)
    do i = 1, n
      write(*, '(A,3A17)') 'W', hex(r_begin(i)), hex(r_end(i)), hex(weight(i))
    end do
    call check(mdr_contact_state(contact, state), 'state')
    do k = 0, 7
      radii(k + 1) = (state%contact_radius * k) / 8
    end do
    call check(mdr_contact_tractions(contact, radii, 8_c_size_t, MDR_ROUTE_BOTH, tau, tau_error, &
                                     p, p_error, 8_c_size_t), 'tractions')
    do k = 1, 8
      write(*, '(A,4A17)') 'T', hex(tau(k)), hex(tau_error(k)), hex(p(k)), hex(p_error(k))
    end do
    call check(mdr_contact_slip_intervals(contact, r_begin, r_end, direction, &
                                          int(max_intervals, c_size_t), n), 'slip_intervals')
    write(*, '(A,I0)') 'L ', n
    do i = 1, n
      write(*, '(A,2A17,1X,I0)') 'I', hex(r_begin(i)), hex(r_end(i)), direction(i)
    end do
  end subroutine
end program
