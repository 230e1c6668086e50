function stop = call_progress(progress, message, numbers)
% call_progress  Calls a fit's progress function with the decoded FitProgress (internal to +mdr,
%   called by mdr_mex after every iteration). true, or a non-zero number, stops the fit; an error
%   of the function stops it too, its message returned as text for mdr_mex to raise.
  try
    answer = progress(mdr.internal.from_json(message, numbers));
  catch failure
    stop = failure.message;
    return
  end
  stop = ~isempty(answer) && (islogical(answer) || isnumeric(answer)) && answer(1) ~= 0;
end
