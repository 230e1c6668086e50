function response = run_analysis(number, request, progress)
% run_analysis  One analysis of libmdr_c (mdr_analysis_run) on a request struct (internal to
%   +mdr): the request as proto3 JSON, the response decoded with its numbers exact; progress: a
%   function handle or [].
  json = mdr.internal.to_json(request);
  if nargin > 2 && ~isempty(progress)
    [text, numbers] = mdr_mex('analysis', number, json, progress);  % call_progress decodes
  else
    [text, numbers] = mdr_mex('analysis', number, json);
  end
  response = mdr.internal.from_json(text, numbers);
end
