/** The one REST client: same origin as the page, JSON in and out, errors as ApiError. */
export class ApiError extends Error {
  constructor(
    readonly status: number,
    message: string,
  ) {
    super(message);
  }
}

async function errorOf(response: Response): Promise<ApiError> {
  let detail = response.statusText;
  try {
    const body = (await response.json()) as { detail?: unknown; error?: unknown };
    detail = String(body.detail ?? body.error ?? detail);
  } catch {
    /* not JSON */
  }
  return new ApiError(response.status, detail || `HTTP ${response.status}`);
}

export async function apiGet<T>(path: string, init?: RequestInit): Promise<T> {
  const response = await fetch(path, { credentials: 'same-origin', ...init });
  if (!response.ok) throw await errorOf(response);
  return (await response.json()) as T;
}

export async function apiPost<T>(path: string, body: BodyInit | object, contentType?: string): Promise<T> {
  const raw = typeof body === 'object' && !(body instanceof Blob) && !(body instanceof ArrayBuffer);
  const response = await fetch(path, {
    method: 'POST',
    credentials: 'same-origin',
    headers: { 'Content-Type': contentType ?? 'application/json' },
    body: raw ? JSON.stringify(body) : (body as BodyInit),
  });
  if (!response.ok) throw await errorOf(response);
  return (await response.json()) as T;
}
